#include "sensor_rig/drivers/lidar/extrinsics.hpp"

#include <cmath>
#include <numbers>

namespace sensor_rig::drivers {

std::array<double, 3> RigidTransform::apply(double px, double py, double pz) const noexcept {
  const auto& r = rotation;
  return {r[0] * px + r[1] * py + r[2] * pz + translation[0], r[3] * px + r[4] * py + r[5] * pz + translation[1],
          r[6] * px + r[7] * py + r[8] * pz + translation[2]};
}

RigidTransform to_transform(const Extrinsics& e) noexcept {
  constexpr double kRad = std::numbers::pi / 180.0;
  const double cr = std::cos(e.roll_deg * kRad), sr = std::sin(e.roll_deg * kRad);
  const double cp = std::cos(e.pitch_deg * kRad), sp = std::sin(e.pitch_deg * kRad);
  const double cy = std::cos(e.yaw_deg * kRad), sy = std::sin(e.yaw_deg * kRad);
  RigidTransform t;
  // Rz(yaw) * Ry(pitch) * Rx(roll), written out.
  t.rotation = {cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
                sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,  //
                -sp,     cp * sr,                cp * cr};
  t.translation = {e.x, e.y, e.z};
  return t;
}

Extrinsics parse_extrinsics(const config::Node& n) {
  Extrinsics e;
  if (!n.expect_map()) return e;
  n.allow_keys({"x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg"});
  constexpr double kMaxOffsetM = 50.0;  // a sensor on this car, not a typo in millimetres
  e.x = n.get_double("x", -kMaxOffsetM, kMaxOffsetM, 0.0);
  e.y = n.get_double("y", -kMaxOffsetM, kMaxOffsetM, 0.0);
  e.z = n.get_double("z", -kMaxOffsetM, kMaxOffsetM, 0.0);
  e.roll_deg = n.get_double("roll_deg", -180.0, 180.0, 0.0);
  e.pitch_deg = n.get_double("pitch_deg", -90.0, 90.0, 0.0);
  e.yaw_deg = n.get_double("yaw_deg", -180.0, 180.0, 0.0);
  return e;
}

}  // namespace sensor_rig::drivers
