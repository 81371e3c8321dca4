#pragma once
// Per-topic stamps that never go backwards when the host clock (CLOCK_REALTIME, vehicle time) is
// stepped back while a device clock keeps running. The device -> vehicle mapping follows the step
// (the clock mapper sees it as a jump); told about the step (realtime_step(), from the caller's
// RealtimeStepDetector), this filter turns the backward jump of the mapped stamps into a
// correction that is slewed out at `slew_fraction` of the elapsed time (0.1: stamps advance at
// 0.9x real rate until they are vehicle time again; a 1 s step back takes 10 s). Steps forward
// pass at once (stamps jump forward: still monotonic), and first take back what is left of a
// correction (a step back undone: the stamps are vehicle time again at once). Backward moves below the step threshold
// (mapping refits) are held the same way; a large backward jump with no host step behind it is the
// device's own (a glitch or a clock reset): passed through and counted, never slewed for seconds.
// Pure: stamps in, stamps out.
#include <cstdint>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

struct MonotonicStampsStatus {
  std::uint64_t backward_steps = 0;  // host steps back absorbed (held, then slewed)
  std::uint64_t held = 0;            // raw stamps at or before the previous output (any size)
  std::uint64_t device_backward = 0; // large backward jumps with no host step: passed through
  Nanos correction_ns = 0;           // now added to the raw stamps (>= 0, slewing to 0)
  Nanos max_correction_ns = 0;
  Nanos last_backward_ns = 0;        // size of the last absorbed step (positive)
};

class MonotonicStamps {
 public:
  // Throws std::invalid_argument unless 0 < slew_fraction < 1 and step_threshold_ns >= 0.
  explicit MonotonicStamps(double slew_fraction = 0.1, Nanos step_threshold_ns = 1'000'000);
  // CLOCK_REALTIME was stepped by `step_ns` (RealtimeStepDetector::observe()'s value); a step back
  // lets the next backward jump of about its size be absorbed, a step forward the next forward jump
  // take back the correction (each within `kAllowanceForNs` of raw time).
  void realtime_step(Nanos step_ns) noexcept;
  // The stamp to publish for the raw (mapped) stamp `raw_ns`.
  Nanos apply(Nanos raw_ns) noexcept;
  [[nodiscard]] const MonotonicStampsStatus& status() const noexcept { return st_; }
  void reset() noexcept;  // a new stream (device reopened): no history

  static constexpr Nanos kAllowanceForNs = 10'000'000'000;

 private:
  double slew_;
  Nanos threshold_;
  bool have_ = false;
  Nanos last_raw_ = 0;
  Nanos last_out_ = 0;
  Nanos allowance_ = 0;        // size of an announced step back not yet absorbed
  Nanos forward_ = 0;          // size of an announced step forward not yet seen in the raw stamps
  Nanos allowance_until_ = 0;  // raw time it expires (set at the first stamp after the step)
  bool allowance_dated_ = false;
  MonotonicStampsStatus st_;
};

}  // namespace sensor_rig::timesync
