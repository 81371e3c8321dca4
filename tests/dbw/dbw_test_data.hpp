#pragma once
// The dbw tests' view of the one test-data helper (tests/support/test_data.hpp).
#include "test_data.hpp"

namespace sensor_rig::dbw::test {
using sensor_rig::test::data_dir;
using sensor_rig::test::read_text;
using sensor_rig::test::source_dir;
}  // namespace sensor_rig::dbw::test
