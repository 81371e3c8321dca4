#include "sensor_rig/dbw/safety/limits.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::dbw::safety {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

std::string_view to_string(Axis a) noexcept {
  switch (a) {
    case Axis::kSteeringAngle: return "steering_angle";
    case Axis::kSteeringTorque: return "steering_torque";
    case Axis::kThrottle: return "throttle";
    case Axis::kBrake: return "brake";
    case Axis::kAccel: return "accel";
    case Axis::kCount: break;
  }
  return "?";
}

const VehicleLimits* find_vehicle(std::string_view name) noexcept {
  for (const auto* v : kVehicles) {
    if (v->name == name) return v;
  }
  return nullptr;
}

double axis_value(const Command& c, Axis a) noexcept {
  switch (a) {
    case Axis::kSteeringAngle: return c.steering_angle;
    case Axis::kSteeringTorque: return c.steering_torque;
    case Axis::kThrottle: return c.throttle;
    case Axis::kBrake: return c.brake;
    case Axis::kAccel: return c.accel;
    case Axis::kCount: break;
  }
  return 0.0;
}

void set_axis_value(Command& c, Axis a, double v) noexcept {
  switch (a) {
    case Axis::kSteeringAngle: c.steering_angle = v; break;
    case Axis::kSteeringTorque: c.steering_torque = v; break;
    case Axis::kThrottle: c.throttle = v; break;
    case Axis::kBrake: c.brake = v; break;
    case Axis::kAccel: c.accel = v; break;
    case Axis::kCount: break;
  }
}

bool LimitResult::rejected() const noexcept {
  for (std::size_t i = 0; i < count; ++i) {
    if (violations[i].rejected) return true;
  }
  return false;
}

void LimitResult::add(const Violation& v) noexcept {
  if (count < violations.size()) violations[count++] = v;
}

double lateral_angle_limit(const VehicleLimits& v, double speed_mps) noexcept {
  const double v2 = speed_mps * speed_mps;
  if (v2 <= 0.0) return kPi / 2;  // standing still: only the range applies
  return std::atan(v.max_lateral_accel * v.wheelbase_m / v2);
}

LimitResult LimitChecker::check(const Command& req, double dt_s, double speed_mps) const noexcept {
  LimitResult r;
  r.applied = req;
  for (std::size_t i = 0; i < kAxes; ++i) {
    const auto axis = static_cast<Axis>(i);
    const AxisLimit& lim = limits_[axis];
    const double want = axis_value(req, axis);
    if (!std::isfinite(want)) {
      r.add({axis, false, true, true, want, 0.0});
      set_axis_value(r.applied, axis, 0.0);
      continue;
    }
    double v = want;
    if (v < lim.min || v > lim.max) {
      const double c = std::clamp(v, lim.min, lim.max);
      r.add({axis, false, lim.action == LimitAction::kReject, false, want, c});
      v = c;
    }
    if (axis == Axis::kSteeringAngle) {
      // Clamped, never rejected: dropping the steering at speed is worse than holding the limit.
      const double lat = lateral_angle_limit(limits_, std::isfinite(speed_mps) ? speed_mps : 0.0);
      if (std::fabs(v) > lat) {
        const double c = std::clamp(v, -lat, lat);
        r.add({axis, false, false, false, want, c, true, false});
        v = c;
      }
    }
    if (have_prev_ && lim.max_rate > 0.0) {
      const double prev = axis_value(prev_, axis);
      const double step = lim.max_rate * std::max(dt_s, 0.0);
      if (std::fabs(v - prev) > step * (1.0 + 1e-9)) {
        const double c = std::clamp(v, prev - step, prev + step);
        r.add({axis, true, lim.action == LimitAction::kReject, false, want, c});
        v = c;
      }
    }
    // After the rate limit: releasing the throttle at once is always allowed.
    if (axis == Axis::kThrottle && std::isfinite(req.brake) && req.brake > limits_.brake_throttle_cutoff && v > 0.0) {
      r.add({axis, false, false, false, want, 0.0, false, true});
      v = 0.0;
    }
    set_axis_value(r.applied, axis, v);
  }
  return r;
}

}  // namespace sensor_rig::dbw::safety
