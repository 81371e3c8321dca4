// SafetySuite, the actuators as measured: engagement ramps from the measured steering angle, the
// pedal interlock (no throttle while braking), the lateral-acceleration limit over speed, and
// unmeasured values keeping the last measurement.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TYPED_TEST(SafetySuite, EngagementRampsFromTheMeasuredSteeringAngle) {
  const auto& lim = TypeParam::kLimits[s::Axis::kSteeringAngle];
  for (const double measured : {0.0, 0.5 * lim.max, 0.5 * lim.min}) {
    SCOPED_TRACE(measured);
    this->core.on_measured(measured, 0.0);
    this->cycle(false);
    this->step(10 * kMs);
    this->ecu_ok();
    auto c = this->cmd(true);
    c.steering_angle = measured > 0 ? lim.min : lim.max;  // as far away as the range allows
    c.throttle = 1.0;
    c.brake = 1.0;
    this->send(c);
    if (lim.action == s::LimitAction::kReject) {
      EXPECT_EQ(this->core.state(), s::State::kDisengaged) << "a step from the measured angle is rejected";
      const auto ev = this->core.take_events();
      ASSERT_FALSE(ev.empty());
      EXPECT_EQ(ev.back().kind, s::EventKind::kLimit);
      EXPECT_TRUE(ev.back().violation.rejected);
      EXPECT_TRUE(ev.back().violation.rate);
      continue;
    }
    ASSERT_EQ(this->core.state(), s::State::kEngaged);
    const auto d = this->core.tick(this->now);
    ASSERT_TRUE(d.active);
    EXPECT_LE(std::fabs(d.command.steering_angle - measured), lim.max_rate * 0.010 * (1 + 1e-9));
    EXPECT_DOUBLE_EQ(d.command.throttle, 0.0) << "throttle with the brake requested";
    EXPECT_LE(d.command.brake, TypeParam::kLimits[s::Axis::kBrake].max_rate * 0.010 * (1 + 1e-9));
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, ThrottleIsZeroWhileTheBrakeIsRequested) {
  this->engage();
  const double cutoff = TypeParam::kLimits.brake_throttle_cutoff;
  for (int i = 0; i < 30; ++i) this->cycle(true);  // throttle ramps to 0.1
  auto c = this->cmd(true);
  this->step(10 * kMs);
  c = this->cmd(true);
  c.brake = cutoff * 0.5;  // below the cutoff: pedals may overlap (brake blending at rest)
  this->send(c);
  EXPECT_GT(this->core.tick(this->now).command.throttle, 0.0);
  this->step(10 * kMs);
  c = this->cmd(true);
  c.brake = cutoff * 1.5;
  this->send(c);
  const auto d = this->core.tick(this->now);
  ASSERT_TRUE(d.active);
  EXPECT_DOUBLE_EQ(d.command.throttle, 0.0);
  EXPECT_GT(d.command.brake, 0.0);
}

TYPED_TEST(SafetySuite, LateralAccelerationLimitsTheSteeringAngleOverSpeed) {
  const auto& v = TypeParam::kLimits;
  const auto& lim = v[s::Axis::kSteeringAngle];
  this->engage();
  // Steers toward `target` within the rate limit (a table may reject faster requests); returns the
  // last applied angle.
  auto steer_toward = [this, max_rate = lim.max_rate](double target, double speed, int steps) {
    double applied = this->core.tick(this->now).command.steering_angle;
    for (int i = 0; i < steps; ++i) {
      this->step(10 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      const double max_step = 0.9 * max_rate * 0.010;
      c.steering_angle = applied + std::clamp(target - applied, -max_step, max_step);
      this->send(c);
      EXPECT_EQ(this->core.state(), s::State::kEngaged);
      applied = this->core.tick(this->now).command.steering_angle;
      EXPECT_LE(speed * speed * std::tan(std::fabs(applied)) / this->core.config().limits.wheelbase_m,
                this->core.config().limits.max_lateral_accel * (1 + 1e-9)) << i;
    }
    return applied;
  };
  for (const double speed : {0.0, 5.0, 10.0, 20.0, 35.0}) {
    SCOPED_TRACE(speed);
    steer_toward(0.0, 0.0, 200);  // straight ahead first: the rate limit keeps the wheel from jumping
    this->core.on_measured(0.0, speed);
    const double applied = steer_toward(0.99 * lim.max, speed, 300);
    // The limit is reached, not undershot.
    const double expect = std::min(0.99 * lim.max, speed > 0 ? std::atan(v.max_lateral_accel * v.wheelbase_m / (speed * speed)) : 1.0);
    EXPECT_NEAR(applied, expect, 1e-9);
  }
}

TYPED_TEST(SafetySuite, UnmeasuredValuesKeepTheLastMeasurement) {
  const auto& lim = TypeParam::kLimits[s::Axis::kSteeringAngle];
  const double measured = 0.5 * lim.max;
  this->core.on_measured(measured, 0.0);
  this->core.on_measured(std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN());
  this->cycle(false);
  this->step(10 * kMs);
  this->ecu_ok();
  auto c = this->cmd(true);
  c.steering_angle = measured + 3 * lim.max_rate * 0.010;  // three steps from the kept measurement
  this->send(c);
  if (lim.action == s::LimitAction::kReject) {
    EXPECT_EQ(this->core.state(), s::State::kDisengaged);
    return;
  }
  ASSERT_EQ(this->core.state(), s::State::kEngaged);
  EXPECT_NEAR(this->core.tick(this->now).command.steering_angle, measured + lim.max_rate * 0.010, 1e-9);
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
