#include "sensor_rig/dbw/mock/vehicle_model.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::dbw::mock {

void VehicleModel::step(const ActuatorRequest& req, double dt) noexcept {
  if (!(dt > 0.0)) return;
  if (req.gear != safety::Gear::kNone && s_.speed < 0.1) s_.gear = req.gear;
  // Steering: lag toward the (limited) target, then slew-rate limit.
  const double target = std::clamp(std::isfinite(req.steer) ? req.steer : s_.steer, -p_.max_steer_rad, p_.max_steer_rad);
  double d = (target - s_.steer) * std::min(1.0, dt / p_.steer_tau_s);
  const double max_d = p_.max_steer_rate * dt;
  d = std::clamp(d, -max_d, max_d);
  s_.steer = std::clamp(s_.steer + d, -p_.max_steer_rad, p_.max_steer_rad);
  // Longitudinal: pedals -> target acceleration, lagged.
  const double thr = std::clamp(std::isfinite(req.throttle) ? req.throttle : 0.0, 0.0, 1.0);
  const double brk = std::clamp(std::isfinite(req.brake) ? req.brake : 0.0, 0.0, 1.0);
  const bool driving = s_.gear == safety::Gear::kDrive || s_.gear == safety::Gear::kReverse;
  double a_target = (driving ? thr * p_.max_drive_accel : 0.0) - p_.drag_per_mps * s_.speed;
  if (s_.speed > 0.0 || a_target > 0.0) a_target -= brk * p_.max_brake_decel;
  if (s_.gear == safety::Gear::kPark) a_target = -p_.max_brake_decel;
  s_.accel += (a_target - s_.accel) * std::min(1.0, dt / p_.accel_tau_s);
  s_.speed = std::clamp(s_.speed + s_.accel * dt, 0.0, p_.max_speed_mps);
  if (s_.speed == 0.0 && s_.accel < 0.0) s_.accel = 0.0;
  // Kinematic bicycle about the rear axle.
  const double dir = s_.gear == safety::Gear::kReverse ? -1.0 : 1.0;
  s_.yaw_rate = dir * s_.speed * std::tan(s_.steer) / p_.wheelbase_m;
  s_.yaw += s_.yaw_rate * dt;
  s_.x += dir * s_.speed * std::cos(s_.yaw) * dt;
  s_.y += dir * s_.speed * std::sin(s_.yaw) * dt;
}

void VehicleModel::wheel_speeds(double out[4]) const noexcept {
  const double half = s_.yaw_rate * p_.track_m / 2.0;
  out[0] = std::max(0.0, s_.speed - half);  // fl: inner wheel when turning left
  out[1] = std::max(0.0, s_.speed + half);
  out[2] = std::max(0.0, s_.speed - half);
  out[3] = std::max(0.0, s_.speed + half);
}

}  // namespace sensor_rig::dbw::mock
