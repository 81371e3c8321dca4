#pragma once
// Per-topic stamps that never go backwards when the host clock (CLOCK_REALTIME, vehicle time) is
// stepped back while a device clock keeps running: the device -> vehicle mapping follows the step
// (the clock mapper sees it as a jump), this filter turns the backward jump of the mapped stamps
// into a correction that is slewed out at `slew_fraction` of the elapsed time (0.1: stamps advance
// at 0.9x real rate until they are vehicle time again; a 1 s step back takes 10 s). Steps forward
// pass at once (stamps jump forward: still monotonic). Pure: stamps in, stamps out.
#include <cstdint>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

struct MonotonicStampsStatus {
  std::uint64_t backward_steps = 0;  // backward jumps of the raw stamps beyond step_threshold_ns
  std::uint64_t held = 0;            // raw stamps at or before the previous output (any size)
  Nanos correction_ns = 0;           // now added to the raw stamps (>= 0, slewing to 0)
  Nanos max_correction_ns = 0;
  Nanos last_backward_ns = 0;        // size of the last backward step (positive)
};

class MonotonicStamps {
 public:
  // Throws std::invalid_argument unless 0 < slew_fraction < 1 and step_threshold_ns >= 0.
  explicit MonotonicStamps(double slew_fraction = 0.1, Nanos step_threshold_ns = 1'000'000);
  // The stamp to publish for the raw (mapped) stamp `raw_ns`: >= every earlier output.
  Nanos apply(Nanos raw_ns) noexcept;
  [[nodiscard]] const MonotonicStampsStatus& status() const noexcept { return st_; }
  void reset() noexcept;  // a new stream (device reopened): no history

 private:
  double slew_;
  Nanos threshold_;
  bool have_ = false;
  Nanos last_raw_ = 0;
  Nanos last_out_ = 0;
  MonotonicStampsStatus st_;
};

}  // namespace sensor_rig::timesync
