#pragma once
// Clock reads live here and in timesync/ only; decoders take time as arguments.
#include <time.h>

#include <cstdint>

namespace sensor_rig {

using Nanos = std::int64_t;  // signed ns; vehicle time is CLOCK_REALTIME (SPEC §6)

// Units of Nanos, for periods, schedules and bounds written as 20 * kMs rather than 20'000'000.
inline constexpr Nanos kUs = 1'000;
inline constexpr Nanos kMs = 1'000'000;
inline constexpr Nanos kSec = 1'000'000'000;

inline Nanos clock_ns(clockid_t id) noexcept {
  timespec ts{};
  ::clock_gettime(id, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}
inline Nanos vehicle_now_ns() noexcept { return clock_ns(CLOCK_REALTIME); }
inline Nanos monotonic_now_ns() noexcept { return clock_ns(CLOCK_MONOTONIC); }

}  // namespace sensor_rig
