// The safety configuration's documented defaults and the generic limit checker on every vehicle's
// table: sane tables, range below/above every axis, no change over a zero or negative interval,
// jerk as the acceleration rate.
#include <gtest/gtest.h>

#include <string>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TEST(SafetyConfig, DefaultsAreTheDocumentedOnes) {
  const s::SafetyConfig c;
  EXPECT_EQ(c.command_timeout_ns, 100 * kMs);
  EXPECT_EQ(c.ecu_timeout_ns, 100 * kMs);
  EXPECT_EQ(c.max_future_ns, 20 * kMs);
  EXPECT_EQ(c.rate_rx_slack_ns, 2 * kMs);
  EXPECT_EQ(c.e2e_tolerance, 3);
  EXPECT_EQ(s::e2e_level_max(c), 7);
}

TEST(LimitChecker, TablesAreSane) {
  for (const auto* v : s::kVehicles) {
    SCOPED_TRACE(std::string(v->name));
    EXPECT_EQ(s::find_vehicle(v->name), v);
    for (const auto& a : v->axes) {
      EXPECT_LT(a.min, a.max);
      EXPECT_GE(a.max_rate, 0.0);
    }
    EXPECT_GE((*v)[s::Axis::kThrottle].min, 0.0);
    EXPECT_LE((*v)[s::Axis::kThrottle].max, 1.0);
    EXPECT_LE((*v)[s::Axis::kAccel].min, 0.0);
    EXPECT_GT(v->wheelbase_m, 1.0);
    EXPECT_GT(v->max_lateral_accel, 0.0);
    EXPECT_LE(v->max_lateral_accel, 5.0);  // ISO 11270 order of magnitude
    EXPECT_GT(v->brake_throttle_cutoff, 0.0);
    EXPECT_LT(v->brake_throttle_cutoff, 0.2);
  }
  EXPECT_EQ(s::find_vehicle("nope"), nullptr);
}

TEST(LimitChecker, RangeBelowAndAboveEveryAxisFollowsTheTablesAction) {
  for (const auto* v : s::kVehicles) {
    SCOPED_TRACE(std::string(v->name));
    const s::LimitChecker chk(*v);  // no previous command: the range alone
    for (std::size_t a = 0; a < s::kAxes; ++a) {
      const auto axis = static_cast<s::Axis>(a);
      const auto& lim = (*v)[axis];
      for (const double want : {lim.min - 0.01, lim.max + 0.01}) {
        SCOPED_TRACE(std::string(s::to_string(axis)) + " " + std::to_string(want));
        s::Command c;
        s::set_axis_value(c, axis, want);
        const auto r = chk.check(c, 0.01);
        ASSERT_EQ(r.count, 1);
        EXPECT_FALSE(r.violations[0].rate);
        EXPECT_EQ(r.violations[0].rejected, lim.action == s::LimitAction::kReject);
        EXPECT_DOUBLE_EQ(s::axis_value(r.applied, axis), want < lim.min ? lim.min : lim.max);
      }
    }
  }
}

TEST(LimitChecker, ZeroOrNegativeIntervalAllowsNoChange) {
  s::LimitChecker chk(s::kParavanRef);
  s::Command c;
  chk.accept(c);
  c.steering_angle = 0.1;
  for (const double dt : {0.0, -0.01}) {
    const auto r = chk.check(c, dt);
    ASSERT_EQ(r.count, 1) << dt;
    EXPECT_TRUE(r.violations[0].rate);
    EXPECT_DOUBLE_EQ(r.applied.steering_angle, 0.0);
  }
  chk.reset();  // no previous command: only the range applies
  EXPECT_EQ(chk.check(c, 0.0).count, 0);
}

TEST(LimitChecker, JerkIsTheAccelerationRate) {
  s::LimitChecker chk(s::kParavanRef);
  s::Command c;
  chk.accept(c);
  c.accel = 2.0;
  const auto r = chk.check(c, 0.1);  // 2 m/s^2 in 0.1 s = 20 m/s^3 > 5
  ASSERT_EQ(r.count, 1);
  EXPECT_EQ(r.violations[0].axis, s::Axis::kAccel);
  EXPECT_TRUE(r.violations[0].rate);
  EXPECT_NEAR(r.applied.accel, 0.5, 1e-12);
  EXPECT_FALSE(r.rejected());
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
