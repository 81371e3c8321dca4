#pragma once
// Polling until a condition holds, for tests that watch threads or other processes.
#include <unistd.h>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::test {

// True as soon as `p()` holds, false when `ms` passed without it; checks every `poll_ms`.
template <class Pred>
bool wait_for(Pred p, int ms, int poll_ms = 5) {
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(ms) * 1'000'000;
  while (!p()) {
    if (monotonic_now_ns() > deadline) return false;
    ::usleep(static_cast<useconds_t>(poll_ms) * 1000);
  }
  return true;
}

}  // namespace sensor_rig::test
