#pragma once
// What a node's publishing loop reports in /diagnostics for one stream: samples written, write
// failures, and the rate. One place for the bookkeeping every node (LIDAR, camera) does alike.
#include <cstdint>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/entity.hpp"

namespace sensor_rig::dds {

class PublishStats {
 public:
  // One sample written at `publish_ns` (vehicle time, taken just before the write). False when the
  // write failed: the caller reports `rc.message()` with the topic it wrote.
  bool count(const Result& rc, Nanos publish_ns) noexcept {
    ++samples_;
    if (last_ns_ != 0 && publish_ns > last_ns_) {
      // An average of the inverse intervals weighted 0.8/0.2: steady over a few samples of jitter,
      // yet a halved rate shows within ~1 s at 10 Hz. A clock step back (publish <= last) is skipped.
      const double inst = 1e9 / static_cast<double>(publish_ns - last_ns_);
      rate_hz_ = rate_hz_ == 0.0 ? inst : 0.8 * rate_hz_ + 0.2 * inst;
    }
    last_ns_ = publish_ns;
    if (rc.ok()) return true;
    ++write_errors_;
    return false;
  }
  // A write that is not this stream's sample rate (a side topic): counted, no rate.
  bool count_write(const Result& rc) noexcept {
    if (rc.ok()) return true;
    ++write_errors_;
    return false;
  }

  [[nodiscard]] std::uint64_t samples() const noexcept { return samples_; }
  [[nodiscard]] std::uint64_t write_errors() const noexcept { return write_errors_; }
  [[nodiscard]] double rate_hz() const noexcept { return rate_hz_; }
  // Vehicle time of the last sample, 0 before the first (a node's "no data for N s").
  [[nodiscard]] Nanos last_ns() const noexcept { return last_ns_; }

 private:
  std::uint64_t samples_ = 0;
  std::uint64_t write_errors_ = 0;
  Nanos last_ns_ = 0;
  double rate_hz_ = 0.0;
};

}  // namespace sensor_rig::dds
