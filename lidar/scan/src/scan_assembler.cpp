// Scan bookkeeping shared by the vendor decoders. See scan_assembler.hpp.
#include "sensor_rig/lidar/scan_assembler.hpp"

#include <utility>

namespace sensor_rig::lidar {

ScanAssembler::ScanAssembler(const ScanAssemblerOptions& options, ScanStats& stats) : options_(options), stats_(stats) {
  spare_.reserve(options_.spare_buffers);  // recycle() never allocates
  cur_ = fresh();
  if (options_.lookahead) nxt_ = fresh();
}

std::optional<Scan> ScanAssembler::flush() noexcept {
  rejected_ = 0;
  std::optional<Scan> out;
  if (cur_.has_data()) {
    out = emit();
  } else {
    recycle(std::move(cur_.scan.points));
  }
  cur_ = fresh();
  if (options_.lookahead) {
    recycle(std::move(nxt_.scan.points));
    nxt_ = fresh();
  }
  return out;
}

}  // namespace sensor_rig::lidar
