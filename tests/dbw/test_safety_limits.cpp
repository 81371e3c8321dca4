// SafetySuite, the limit tables: NaN/inf, ranges clamped or rejected per table and reported, rate
// limits over many steps, and stamps (equal, earlier, racing ahead of arrival, jittered delivery)
// that must not widen a step.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TYPED_TEST(SafetySuite, NanOrInfCommandDisengagesOnEveryAxis) {
  for (std::size_t k = 0; k < 2 * s::kAxes; ++k) {
    const std::size_t a = k % s::kAxes;
    const double bad = k < s::kAxes ? std::numeric_limits<double>::quiet_NaN() : -std::numeric_limits<double>::infinity();
    SCOPED_TRACE(std::string(s::to_string(static_cast<s::Axis>(a))) + " = " + std::to_string(bad));
    this->engage();
    auto c = this->cmd(true);
    this->step(10 * kMs);
    c.stamp = this->vnow();
    s::set_axis_value(c, static_cast<s::Axis>(a), bad);
    this->send(c);
    EXPECT_EQ(this->core.state(), s::State::kDisengaged);
    EXPECT_EQ(this->core.reason(), s::Reason::kInvalidCommand);
    EXPECT_FALSE(this->core.tick(this->now).active);
  }
}

TYPED_TEST(SafetySuite, OutOfRangeClampedOrRejectedPerTableAndReported) {
  const auto& lim = TypeParam::kLimits;
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    SCOPED_TRACE(std::string(s::to_string(axis)));
    this->engage();
    auto c = this->cmd(true);
    this->step(10 * kMs);
    c.stamp = this->vnow();
    // Far beyond the range: both range and (for engaged) rate are violated.
    s::set_axis_value(c, axis, lim[axis].max + 10.0);
    this->send(c);
    const auto ev = this->core.take_events();
    bool reported = false;
    for (const auto& e : ev) reported = reported || (e.kind == s::EventKind::kLimit && e.violation.axis == axis);
    EXPECT_TRUE(reported);
    if (lim[axis].action == s::LimitAction::kReject) {
      EXPECT_EQ(this->core.state(), s::State::kDisengaged);
      EXPECT_EQ(this->core.reason(), s::Reason::kInvalidCommand);
    } else {
      EXPECT_EQ(this->core.state(), s::State::kEngaged);
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active);
      EXPECT_LE(s::axis_value(d.command, axis), lim[axis].max);
    }
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, RateLimitsHoldOverManySteps) {
  const auto& lim = TypeParam::kLimits;
  this->engage();
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    if (lim[axis].action == s::LimitAction::kReject || lim[axis].max_rate <= 0) continue;
    SCOPED_TRACE(std::string(s::to_string(axis)));
    double prev = s::axis_value(this->core.tick(this->now).command, axis);
    for (int i = 0; i < 20; ++i) {
      this->step(10 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      s::set_axis_value(c, axis, lim[axis].max);  // a step to the maximum
      this->send(c);
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active);
      const double v = s::axis_value(d.command, axis);
      EXPECT_LE(std::fabs(v - prev), lim[axis].max_rate * 0.010 * (1 + 1e-9) + 1e-12) << i;
      prev = v;
    }
  }
}

TYPED_TEST(SafetySuite, LaterSeqWithEqualOrEarlierStampCannotDodgeRateLimits) {
  const auto& lim = TypeParam::kLimits;
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    if (lim[axis].max_rate <= 0) continue;
    SCOPED_TRACE(std::string(s::to_string(axis)));
    this->engage();
    const double before = s::axis_value(this->core.tick(this->now).command, axis);
    const Nanos last_stamp = this->vnow();
    const auto ignored = this->core.counters().ignored_stamp;
    for (const Nanos back : {Nanos{0}, 5 * kMs}) {
      this->step(1 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      c.stamp = last_stamp - back;  // higher seq, stamp not advancing
      s::set_axis_value(c, axis, before + lim[axis].max_rate * 0.010);
      this->send(c);
    }
    EXPECT_EQ(this->core.counters().ignored_stamp, ignored + 2);
    EXPECT_EQ(this->core.state(), s::State::kEngaged);
    const auto d = this->core.tick(this->now);
    ASSERT_TRUE(d.active);
    EXPECT_DOUBLE_EQ(s::axis_value(d.command, axis), before) << "the command with a stale stamp was applied";
    // The ignored commands did not refresh the command either: it times out from its own stamp.
    this->step(last_stamp + 100 * kMs - this->vnow());
    this->ecu_ok();
    EXPECT_TRUE(this->core.tick(this->now).active);
    this->step(1 * kMs);
    this->ecu_ok();
    EXPECT_FALSE(this->core.tick(this->now).active);
    EXPECT_EQ(this->core.reason(), s::Reason::kCommandTimeout);
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, StampsRacingAheadOfArrivalCannotWidenAStep) {
  const auto& lim = TypeParam::kLimits;
  const double window_s = 0.001 + static_cast<double>(this->core.config().rate_rx_slack_ns) * 1e-9;
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    if (lim[axis].max_rate <= 0) continue;
    SCOPED_TRACE(std::string(s::to_string(axis)));
    this->engage();
    const double before = s::axis_value(this->core.tick(this->now).command, axis);
    // Arrives 1 ms after the last one but claims 20 ms (the most a stamp may lead): a 10 ms step
    // fits the stamps, not the arrival times.
    this->step(1 * kMs);
    this->ecu_ok();
    auto c = this->cmd(true);
    c.stamp = this->vnow() + this->core.config().max_future_ns - 1 * kMs;
    s::set_axis_value(c, axis, before + lim[axis].max_rate * 0.010);
    this->send(c);
    if (lim[axis].action == s::LimitAction::kReject) {
      EXPECT_EQ(this->core.state(), s::State::kDisengaged);
      EXPECT_EQ(this->core.reason(), s::Reason::kInvalidCommand);
    } else {
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active);
      const double v = s::axis_value(d.command, axis);
      EXPECT_GT(v, before);
      EXPECT_LE(v - before, lim[axis].max_rate * window_s * (1 + 1e-9));
    }
    this->step(20 * kMs);
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, SteadyRampWithDeliveryJitterIsNotLimited) {
  const auto& lim = TypeParam::kLimits;
  // Throttle and brake ramp in separate runs: together the pedal interlock would cut the throttle.
  for (const auto skip : {s::Axis::kBrake, s::Axis::kThrottle}) {
    SCOPED_TRACE(std::string("without ") + std::string(s::to_string(skip)));
    this->engage();
    for (int i = 0; i < 20 && skip == s::Axis::kThrottle; ++i) {  // release the throttle first
      this->step(10 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      c.throttle = 0.0;
      this->send(c);
    }
    const auto start = this->core.tick(this->now).command;
    const Nanos jitter = this->core.config().rate_rx_slack_ns * 3 / 4;
    const auto clamped = this->core.counters().clamped;  // engaging ramps from the measured state
    Nanos stamp = this->vnow();
    for (int i = 1; i <= 20; ++i) {
      stamp += 10 * kMs;
      this->now = stamp - this->offset + (i % 2 == 0 ? jitter : 0);  // every other command delivered late
      this->ecu_ok();
      auto c = this->cmd(true);
      c.stamp = stamp;
      for (std::size_t a = 0; a < s::kAxes; ++a) {
        const auto axis = static_cast<s::Axis>(a);
        const double ramp = axis == skip ? 0.0 : 0.9 * lim[axis].max_rate * 0.010 * i;
        s::set_axis_value(c, axis, s::axis_value(start, axis) + ramp);
      }
      this->send(c);
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active) << i;
      for (std::size_t a = 0; a < s::kAxes; ++a) {
        const auto axis = static_cast<s::Axis>(a);
        EXPECT_DOUBLE_EQ(s::axis_value(d.command, axis), s::axis_value(c, axis)) << s::to_string(axis) << " at " << i;
      }
    }
    EXPECT_EQ(this->core.counters().clamped, clamped);
    EXPECT_EQ(this->core.counters().rejected, 0U);
    this->cycle(false);
  }
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
