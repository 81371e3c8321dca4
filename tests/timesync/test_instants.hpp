#pragma once
// The timesync tests' reference instant, and a time as sensors count it: microseconds past the hour.
#include <cstdint>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/floor_div.hpp"
#include "sensor_rig/timesync/top_of_hour.hpp"

namespace sensor_rig::timesync::test {

inline constexpr Nanos kHour10 = 1'795'255'200'000'000'000;  // 2026-11-21 10:00:00 UTC

inline std::uint32_t us_of(Nanos t) { return static_cast<std::uint32_t>(floor_mod(t, kHourNs) / 1000); }

}  // namespace sensor_rig::timesync::test
