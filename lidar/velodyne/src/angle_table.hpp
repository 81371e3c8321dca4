#pragma once
// sin/cos of every azimuth count (0.01°), built once at start-up; shared read-only by decoders.
#include <array>
#include <cstddef>

namespace sensor_rig::lidar::velodyne {

struct AngleTable {
  AngleTable() noexcept;
  std::array<float, 36000> sin;
  std::array<float, 36000> cos;
};
extern const AngleTable kAngles;

}  // namespace sensor_rig::lidar::velodyne
