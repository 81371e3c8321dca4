#pragma once
// The next captured frame of a source under test, skipping timeouts (and, where a test drops
// packets on purpose, incomplete frames) until `budget_ms` runs out.
#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::test {

inline Capture next_frame(FrameSource& s, int budget_ms, bool skip_incomplete = false) {
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(budget_ms) * 1'000'000;
  Capture c;
  while (monotonic_now_ns() < deadline) {
    c = s.next(50);
    const bool skip = c.status == CaptureStatus::kTimeout || (skip_incomplete && c.status == CaptureStatus::kIncomplete);
    if (!skip) return c;
  }
  return c;
}

}  // namespace sensor_rig::camera::test
