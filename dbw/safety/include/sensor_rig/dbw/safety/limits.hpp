#pragma once
// Actuator limits: one constexpr table per vehicle, one generic checker (opendbc style).
// Each axis has a range and a rate limit (per second: steering rate, throttle/brake slew, jerk for
// acceleration); a violation is clamped or rejected as configured and always reported.
#include <array>
#include <cstdint>
#include <string_view>

#include "sensor_rig/dbw/safety/command.hpp"

namespace sensor_rig::dbw::safety {

enum class Axis : std::uint8_t { kSteeringAngle, kSteeringTorque, kThrottle, kBrake, kAccel, kCount };
inline constexpr std::size_t kAxes = static_cast<std::size_t>(Axis::kCount);
[[nodiscard]] std::string_view to_string(Axis a) noexcept;

enum class LimitAction : std::uint8_t { kClamp, kReject };

struct AxisLimit {
  double min = 0.0;
  double max = 0.0;
  double max_rate = 0.0;  // |d/dt| per second; 0 = unlimited
  LimitAction action = LimitAction::kClamp;
};

struct VehicleLimits {
  std::string_view name;
  std::array<AxisLimit, kAxes> axes{};
  // Speed-dependent steering limit (ISO 11270 style): the road-wheel angle may not ask for more
  // than this lateral acceleration at the measured speed (kinematic bicycle: a = v^2 tan(delta) / L).
  double wheelbase_m = 2.94;
  double max_lateral_accel = 3.0;  // m/s^2
  // Throttle is forced to zero while the brake request exceeds this (pedals never fight).
  double brake_throttle_cutoff = 0.05;
  [[nodiscard]] constexpr const AxisLimit& operator[](Axis a) const noexcept { return axes[static_cast<std::size_t>(a)]; }
  [[nodiscard]] constexpr AxisLimit& operator[](Axis a) noexcept { return axes[static_cast<std::size_t>(a)]; }
};

// The reference protocol's vehicle (mock ECU): road-wheel angle ±0.6 rad at 0.8 rad/s, column torque
// ±8 Nm, pedals 0..1 slewing at 2/s, acceleration -8..3 m/s^2 with jerk 5 m/s^3.
inline constexpr VehicleLimits kParavanRef{
    "paravan_ref",
    {{{-0.6, 0.6, 0.8, LimitAction::kClamp},
      {-8.0, 8.0, 40.0, LimitAction::kClamp},
      {0.0, 1.0, 2.0, LimitAction::kClamp},
      {0.0, 1.0, 4.0, LimitAction::kClamp},
      {-8.0, 3.0, 5.0, LimitAction::kClamp}}},
    2.94,
    3.0,
    0.05};

// The research car (Mercedes E-Class with Paravan SWA): conservative test-track limits; range
// violations are rejected (disengage) instead of clamped.
inline constexpr VehicleLimits kEClassTrack{
    "eclass_track",
    {{{-0.5, 0.5, 0.5, LimitAction::kReject},
      {-5.0, 5.0, 20.0, LimitAction::kReject},
      {0.0, 0.6, 1.0, LimitAction::kClamp},
      {0.0, 1.0, 3.0, LimitAction::kClamp},
      {-6.0, 2.0, 3.0, LimitAction::kClamp}}},
    2.94,
    2.5,
    0.05};

inline constexpr std::array<const VehicleLimits*, 2> kVehicles{&kParavanRef, &kEClassTrack};
[[nodiscard]] const VehicleLimits* find_vehicle(std::string_view name) noexcept;

struct Violation {
  Axis axis = Axis::kSteeringAngle;
  bool rate = false;       // rate (or jerk) limit, else range
  bool rejected = false;   // rejected rather than clamped
  bool not_finite = false; // NaN/inf: always rejected
  double requested = 0.0;
  double applied = 0.0;
  bool lateral = false;    // steering beyond the lateral-acceleration limit at the measured speed (clamped)
  bool interlock = false;  // throttle zeroed because the brake is requested
};

struct LimitResult {
  Command applied;
  std::uint8_t count = 0;
  std::array<Violation, kAxes * 2> violations{};
  [[nodiscard]] bool rejected() const noexcept;
  void add(const Violation& v) noexcept;
};

// Generic checker: range, then rate against the previously applied command.
class LimitChecker {
 public:
  explicit LimitChecker(const VehicleLimits& limits) : limits_(limits) {}
  // `dt_s`: time since the previously applied command. Rates are checked whenever there is a
  // previous command (accept() since the last reset()); dt_s <= 0 then allows no change at all
  // (fail-safe: a zero or negative interval must not switch the rate limits off). `speed_mps`: the
  // measured speed, for the lateral-acceleration steering limit.
  [[nodiscard]] LimitResult check(const Command& requested, double dt_s, double speed_mps = 0.0) const noexcept;
  // Remember what was actually sent (the basis of the next rate check).
  void accept(const Command& applied) noexcept {
    prev_ = applied;
    have_prev_ = true;
  }
  void reset() noexcept { have_prev_ = false; }
  [[nodiscard]] const VehicleLimits& limits() const noexcept { return limits_; }

 private:
  VehicleLimits limits_;
  Command prev_{};
  bool have_prev_ = false;
};

// The largest road-wheel angle (rad) within the table's lateral acceleration at `speed_mps`.
[[nodiscard]] double lateral_angle_limit(const VehicleLimits& v, double speed_mps) noexcept;

[[nodiscard]] double axis_value(const Command& c, Axis a) noexcept;
void set_axis_value(Command& c, Axis a, double v) noexcept;

}  // namespace sensor_rig::dbw::safety
