#include "matcher_log.hpp"

#include <cerrno>
#include <cinttypes>
#include <cstring>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::drivers {

MatcherLog::MatcherLog(const std::string& path) {
  if (path.empty()) return;
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    log::warn("fusion", "matcher log " + path + ": " + std::strerror(errno) + " (not written)");
    return;
  }
  std::fputs("event,source,seq,stamp_ns,arrival_ns,span_ns,unsynchronized,sweep,complete\n", file_);
}

MatcherLog::~MatcherLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void MatcherLog::scan(std::uint32_t source, std::uint64_t seq, Nanos stamp, Nanos arrival, Nanos span, bool unsynchronized,
                      std::int64_t sweep) {
  if (file_ == nullptr) return;
  std::fprintf(file_, "scan,%" PRIu32 ",%" PRIu64 ",%" PRId64 ",%" PRId64 ",%" PRId64 ",%d,%" PRId64 ",\n", source, seq, stamp,
               arrival, span, unsynchronized ? 1 : 0, sweep);
}

void MatcherLog::sweep(Nanos now, std::uint64_t id, bool complete) {
  if (file_ == nullptr) return;
  std::fprintf(file_, "sweep,,,,%" PRId64 ",,,%" PRIu64 ",%d\n", now, id, complete ? 1 : 0);
  std::fflush(file_);
}

}  // namespace sensor_rig::drivers
