#pragma once
// Where a LIDAR sits on the car: its frame (lidar_<name>) in base_link (REP 103: x forward, y left,
// z up, metres), as the rig config's `extrinsics: {x, y, z, roll_deg, pitch_deg, yaw_deg}`. The
// rotation is the ROS (tf2) convention: R = Rz(yaw) * Ry(pitch) * Rx(roll), fixed axes, so a point
// p in the LIDAR frame is R * p + (x, y, z) in base_link.
#include <array>
#include <optional>

#include "sensor_rig/common/config_node.hpp"

namespace sensor_rig::drivers {

struct Extrinsics {
  double x = 0.0, y = 0.0, z = 0.0;                     // metres
  double roll_deg = 0.0, pitch_deg = 0.0, yaw_deg = 0.0;  // degrees
};

// The extrinsics as a rigid transform: base_link point = rotation * lidar point + translation.
struct RigidTransform {
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major 3x3
  std::array<double, 3> translation{0, 0, 0};

  [[nodiscard]] std::array<double, 3> apply(double px, double py, double pz) const noexcept;
};

RigidTransform to_transform(const Extrinsics& e) noexcept;

// Parses and validates one `extrinsics:` map: all six keys optional (0), translation within
// +-50 m of base_link, roll and yaw in [-180, 180], pitch in [-90, 90] (beyond that the same pose
// has another name). Problems go to the node's list.
Extrinsics parse_extrinsics(const config::Node& n);

}  // namespace sensor_rig::drivers
