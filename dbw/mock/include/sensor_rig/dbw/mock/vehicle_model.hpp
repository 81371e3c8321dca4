#pragma once
// Kinematic bicycle model with first-order actuator lag and actuator limits. Pure; time is `dt`.
#include "sensor_rig/dbw/safety/command.hpp"

namespace sensor_rig::dbw::mock {

struct VehicleParams {
  double wheelbase_m = 2.94;        // Mercedes E-Class (W213)
  double track_m = 1.60;
  double max_steer_rad = 0.6;       // road-wheel angle limit
  double max_steer_rate = 0.8;      // rad/s actuator slew
  double steer_tau_s = 0.10;        // steering actuator lag
  double accel_tau_s = 0.25;        // powertrain/brake lag
  double max_drive_accel = 3.0;     // m/s^2 at full throttle
  double max_brake_decel = 9.0;     // m/s^2 at full brake
  double drag_per_mps = 0.015;      // coasting deceleration per m/s
  double max_speed_mps = 70.0;
};

struct VehicleState {
  double x = 0.0, y = 0.0, yaw = 0.0;  // m, m, rad (REP 103)
  double speed = 0.0;                  // m/s, >= 0 in drive
  double steer = 0.0;                  // actual road-wheel angle, rad
  double accel = 0.0;                  // actual longitudinal acceleration, m/s^2
  double yaw_rate = 0.0;               // rad/s
  safety::Gear gear = safety::Gear::kDrive;
};

struct ActuatorRequest {
  double steer = 0.0;     // rad
  double throttle = 0.0;  // 0..1
  double brake = 0.0;     // 0..1
  safety::Gear gear = safety::Gear::kNone;
};

class VehicleModel {
 public:
  explicit VehicleModel(VehicleParams p = {}) : p_(p) {}
  void step(const ActuatorRequest& req, double dt_s) noexcept;
  [[nodiscard]] const VehicleState& state() const noexcept { return s_; }
  [[nodiscard]] const VehicleParams& params() const noexcept { return p_; }
  // Wheel speeds (fl, fr, rl, rr) in m/s from speed and yaw rate.
  void wheel_speeds(double out[4]) const noexcept;
  void set_speed(double v) noexcept { s_.speed = v; }

 private:
  VehicleParams p_;
  VehicleState s_;
};

}  // namespace sensor_rig::dbw::mock
