#pragma once
// The actuator command as the safety core sees it (from rt/vehicle/dbw/cmd, after decoding).
#include <cstdint>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::dbw::safety {

enum class Gear : std::uint8_t { kNone = 0, kPark = 1, kReverse = 2, kNeutral = 3, kDrive = 4 };

// Who sent a command: the DDS publication handle of its writer (0 when there is only one source).
using WriterId = std::uint64_t;

struct Command {
  Nanos stamp = 0;           // the command's own stamp (vehicle time): a plausibility check only
  std::uint64_t seq = 0;     // strictly increasing per writer
  WriterId writer = 0;
  bool enable = false;
  double steering_angle = 0.0;   // road-wheel angle, rad, + = left (REP 103)
  double steering_torque = 0.0;  // Nm at the steering column (torque mode)
  double throttle = 0.0;         // 0..1
  double brake = 0.0;            // 0..1
  double accel = 0.0;            // requested longitudinal acceleration, m/s^2
  Gear gear = Gear::kNone;       // none = keep
};

}  // namespace sensor_rig::dbw::safety
