#pragma once
// Degrees to radians: sensor formats and calibration files give angles in degrees, geometry wants
// radians. One constant instead of one per file.
#include <numbers>

namespace sensor_rig {

inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;

}  // namespace sensor_rig
