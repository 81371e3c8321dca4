#pragma once
// The dbw tests' view of the one test-data helper (tests/support/test_data.hpp), and the unit their
// schedules are written in.
#include "sensor_rig/common/clock.hpp"
#include "test_data.hpp"

namespace sensor_rig::dbw::test {
using sensor_rig::test::data_dir;
using sensor_rig::test::read_text;
using sensor_rig::test::source_dir;

inline constexpr Nanos kMs = 1'000'000;
}  // namespace sensor_rig::dbw::test
