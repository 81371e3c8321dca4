#pragma once
// Test support for the Ouster decoder: capture paths; the packet and metadata builders
// (lidar/mock/ouster_packet_builder.hpp) under their test:: names.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_data.hpp"
#include <vector>

#include "sensor_rig/lidar/mock/ouster_packet_builder.hpp"
#include "sensor_rig/lidar/ouster/profile.hpp"

namespace sensor_rig::lidar::ouster::test {

inline std::string data_dir() { return sensor_rig::test::data_dir().string(); }
inline std::string ouster_file(const std::string& name) { return data_dir() + "/lidar/ouster/" + name; }
using sensor_rig::test::exists;
using sensor_rig::test::read_text;

using namespace builder;  // NOLINT(google-build-using-namespace): tests name the builder as test::

}  // namespace sensor_rig::lidar::ouster::test
