// The safety core with a fake clock: every transition and every fault, run by every vehicle's limit
// table through one typed suite (opendbc style), plus the generic limit checker.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sensor_rig/dbw/safety/safety_core.hpp"

namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;

namespace {

constexpr Nanos kMs = 1'000'000;

struct ParavanRef {
  static constexpr const s::VehicleLimits& limits = s::kParavanRef;
};
struct EClassTrack {
  static constexpr const s::VehicleLimits& limits = s::kEClassTrack;
};

template <class V>
class SafetySuite : public ::testing::Test {
 protected:
  s::SafetyConfig cfg() {
    s::SafetyConfig c;
    c.limits = V::limits;
    return c;
  }
  s::SafetyCore core{cfg()};
  Nanos now = 1'000'000'000'000;
  std::uint64_t seq = 0;

  s::Command cmd(bool enable) {
    s::Command c;
    c.stamp = now;
    c.seq = ++seq;
    c.enable = enable;
    c.steering_angle = 0.1 * V::limits[s::Axis::steering_angle].max;
    c.throttle = 0.1;
    return c;
  }
  void ecu_ok() { core.on_ecu_status({true, false, false, false, 0}, now); }
  void step(Nanos dt) { now += dt; }
  // Steady 10 ms cycle: ECU status + command.
  void cycle(bool enable) {
    step(10 * kMs);
    ecu_ok();
    core.on_command(cmd(enable), now);
  }
  void engage() {
    cycle(false);
    cycle(true);
    ASSERT_EQ(core.state(), s::State::engaged);
    core.take_events();
  }
  s::Reason last_transition_reason() {
    s::Reason r = s::Reason::none;
    for (const auto& e : core.take_events()) {
      if (e.kind == s::EventKind::transition) r = e.reason;
    }
    return r;
  }
};

using Vehicles = ::testing::Types<ParavanRef, EClassTrack>;
TYPED_TEST_SUITE(SafetySuite, Vehicles);

TYPED_TEST(SafetySuite, EngagesOnlyOnEnableEdgeWithEverythingFresh) {
  this->ecu_ok();
  // Enable held from the first command counts as an edge (implicit false before).
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  EXPECT_EQ(this->last_transition_reason(), s::Reason::enabled);
  const auto d = this->core.tick(this->now);
  EXPECT_TRUE(d.active);
  EXPECT_DOUBLE_EQ(d.command.throttle, 0.1);
}

TYPED_TEST(SafetySuite, EnableHeldAfterDisengageDoesNotReengage) {
  this->engage();
  this->cycle(false);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->last_transition_reason(), s::Reason::enable_released);
  EXPECT_FALSE(this->core.tick(this->now).active);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, RefusesWithoutEcuStatusOrWhenNotReady) {
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  auto ev = this->core.take_events();
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.back().kind, s::EventKind::engage_refused);
  EXPECT_EQ(ev.back().reason, s::Reason::ecu_timeout);
  // The edge is consumed: a ready ECU later does not engage while enable stays true.
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->step(10 * kMs);
  this->core.on_ecu_status({false, false, false, false, 0}, this->now);
  this->core.on_command(this->cmd(false), this->now);
  this->step(1 * kMs);
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  ev = this->core.take_events();
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.back().reason, s::Reason::ecu_not_ready);
}

TYPED_TEST(SafetySuite, RefusesDuringOverrideOrFault) {
  this->cycle(false);
  this->core.on_ecu_status({true, false, true, false, 0}, this->now);
  this->step(1 * kMs);
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.take_events().back().reason, s::Reason::driver_override);
  this->step(1 * kMs);
  this->core.on_command(this->cmd(false), this->now);
  this->core.on_ecu_status({true, false, false, true, 7}, this->now);
  this->step(1 * kMs);
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.take_events().back().reason, s::Reason::ecu_fault);
}

TYPED_TEST(SafetySuite, CommandTimeoutSendsNeutralNeverTheStaleCommand) {
  this->engage();
  // ECU keeps reporting; commands stop.
  for (int i = 0; i < 9; ++i) {
    this->step(10 * kMs);
    this->ecu_ok();
    ASSERT_TRUE(this->core.tick(this->now).active) << i;  // 10..90 ms old: still fresh
  }
  this->step(10 * kMs);
  this->ecu_ok();
  EXPECT_TRUE(this->core.tick(this->now).active);  // exactly 100 ms: at the limit
  this->step(1 * kMs);
  const auto d = this->core.tick(this->now);
  EXPECT_FALSE(d.active);
  EXPECT_EQ(this->core.reason(), s::Reason::command_timeout);
  // Commands resume but enable stays true: no re-engagement without a new edge.
  this->cycle(true);
  EXPECT_FALSE(this->core.tick(this->now).active);
}

TYPED_TEST(SafetySuite, StaleOrReplayedCommandsAreIgnored) {
  this->engage();
  auto old = this->cmd(true);
  old.stamp = this->now - 150 * kMs;
  this->core.on_command(old, this->now);
  EXPECT_EQ(this->core.counters().ignored_stale, 1U);
  auto replay = this->cmd(true);
  replay.seq = 1;
  this->core.on_command(replay, this->now);
  EXPECT_EQ(this->core.counters().ignored_sequence, 1U);
  auto future = this->cmd(true);
  future.stamp = this->now + 50 * kMs;
  this->core.on_command(future, this->now);
  EXPECT_EQ(this->core.counters().ignored_stale, 2U);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, EcuStatusTimeout) {
  this->engage();
  for (int i = 0; i < 10; ++i) {
    this->step(10 * kMs);
    this->core.on_command(this->cmd(true), this->now);
    this->core.tick(this->now);
  }
  EXPECT_EQ(this->core.state(), s::State::engaged);
  this->step(2 * kMs);
  this->core.on_command(this->cmd(true), this->now);
  EXPECT_FALSE(this->core.tick(this->now).active);
  EXPECT_EQ(this->core.reason(), s::Reason::ecu_timeout);
}

TYPED_TEST(SafetySuite, E2eErrorsBeyondTolerance) {
  this->engage();
  const int tol = this->core.config().e2e_tolerance;
  for (int i = 0; i < tol; ++i) this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  this->core.on_e2e(true, this->now);  // a good frame pays one back
  this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::e2e_errors);
  // Still beyond tolerance: a new edge is refused.
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  for (int i = 0; i < 10; ++i) this->core.on_e2e(true, this->now);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, DriverOverrideLatchedUntilNewEnable) {
  this->engage();
  this->step(10 * kMs);
  this->core.on_ecu_status({true, true, true, false, 0}, this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::driver_override);
  for (int i = 0; i < 5; ++i) this->cycle(true);  // override gone, enable held
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, EcuFaultAndNotReadyDisengage) {
  this->engage();
  this->core.on_ecu_status({true, true, false, true, 3}, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::ecu_fault);
  this->engage();
  this->core.on_ecu_status({false, true, false, false, 0}, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::ecu_not_ready);
}

TYPED_TEST(SafetySuite, BusOffDisengagesAndBlocksEngage) {
  this->engage();
  this->core.on_bus_state(true, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::bus_off);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->core.on_bus_state(false, this->now);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, NanCommandDisengagesOnEveryAxis) {
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    SCOPED_TRACE(std::string(s::to_string(static_cast<s::Axis>(a))));
    this->engage();
    auto c = this->cmd(true);
    this->step(10 * kMs);
    c.stamp = this->now;
    s::set_axis_value(c, static_cast<s::Axis>(a), std::numeric_limits<double>::quiet_NaN());
    this->core.on_command(c, this->now);
    EXPECT_EQ(this->core.state(), s::State::disengaged);
    EXPECT_EQ(this->core.reason(), s::Reason::invalid_command);
    EXPECT_FALSE(this->core.tick(this->now).active);
  }
}

TYPED_TEST(SafetySuite, OutOfRangeClampedOrRejectedPerTableAndReported) {
  const auto& lim = TypeParam::limits;
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    SCOPED_TRACE(std::string(s::to_string(axis)));
    this->engage();
    auto c = this->cmd(true);
    this->step(10 * kMs);
    c.stamp = this->now;
    // Far beyond the range: both range and (for engaged) rate are violated.
    s::set_axis_value(c, axis, lim[axis].max + 10.0);
    this->core.on_command(c, this->now);
    const auto ev = this->core.take_events();
    bool reported = false;
    for (const auto& e : ev) reported = reported || (e.kind == s::EventKind::limit && e.violation.axis == axis);
    EXPECT_TRUE(reported);
    if (lim[axis].action == s::LimitAction::reject) {
      EXPECT_EQ(this->core.state(), s::State::disengaged);
      EXPECT_EQ(this->core.reason(), s::Reason::invalid_command);
    } else {
      EXPECT_EQ(this->core.state(), s::State::engaged);
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active);
      EXPECT_LE(s::axis_value(d.command, axis), lim[axis].max);
    }
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, RateLimitsHoldOverManySteps) {
  const auto& lim = TypeParam::limits;
  this->engage();
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    if (lim[axis].action == s::LimitAction::reject || lim[axis].max_rate <= 0) continue;
    SCOPED_TRACE(std::string(s::to_string(axis)));
    double prev = s::axis_value(this->core.tick(this->now).command, axis);
    for (int i = 0; i < 20; ++i) {
      this->step(10 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      s::set_axis_value(c, axis, lim[axis].max);  // a step to the maximum
      this->core.on_command(c, this->now);
      const auto d = this->core.tick(this->now);
      ASSERT_TRUE(d.active);
      const double v = s::axis_value(d.command, axis);
      EXPECT_LE(std::fabs(v - prev), lim[axis].max_rate * 0.010 * (1 + 1e-9) + 1e-12) << i;
      prev = v;
    }
  }
}

TYPED_TEST(SafetySuite, LaterSeqWithEqualOrEarlierStampCannotDodgeRateLimits) {
  const auto& lim = TypeParam::limits;
  for (std::size_t a = 0; a < s::kAxes; ++a) {
    const auto axis = static_cast<s::Axis>(a);
    if (lim[axis].max_rate <= 0) continue;
    SCOPED_TRACE(std::string(s::to_string(axis)));
    this->engage();
    const double before = s::axis_value(this->core.tick(this->now).command, axis);
    const Nanos last_stamp = this->now;
    const auto ignored = this->core.counters().ignored_stamp;
    for (const Nanos back : {Nanos{0}, 5 * kMs}) {
      this->step(1 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      c.stamp = last_stamp - back;  // higher seq, stamp not advancing
      s::set_axis_value(c, axis, before + lim[axis].max_rate * 0.010);
      this->core.on_command(c, this->now);
    }
    EXPECT_EQ(this->core.counters().ignored_stamp, ignored + 2);
    EXPECT_EQ(this->core.state(), s::State::engaged);
    const auto d = this->core.tick(this->now);
    ASSERT_TRUE(d.active);
    EXPECT_DOUBLE_EQ(s::axis_value(d.command, axis), before) << "the command with a stale stamp was applied";
    // The ignored commands did not refresh the command either: it times out from its own stamp.
    this->step(last_stamp + 100 * kMs - this->now);
    this->ecu_ok();
    EXPECT_TRUE(this->core.tick(this->now).active);
    this->step(1 * kMs);
    this->ecu_ok();
    EXPECT_FALSE(this->core.tick(this->now).active);
    EXPECT_EQ(this->core.reason(), s::Reason::command_timeout);
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, StampsRacingAheadOfArrivalCannotWidenAStep) {
  const auto& lim = TypeParam::limits;
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
    c.stamp = this->now + this->core.config().max_future_ns - 1 * kMs;
    s::set_axis_value(c, axis, before + lim[axis].max_rate * 0.010);
    this->core.on_command(c, this->now);
    if (lim[axis].action == s::LimitAction::reject) {
      EXPECT_EQ(this->core.state(), s::State::disengaged);
      EXPECT_EQ(this->core.reason(), s::Reason::invalid_command);
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
  const auto& lim = TypeParam::limits;
  this->engage();
  const auto start = this->core.tick(this->now).command;
  const Nanos jitter = this->core.config().rate_rx_slack_ns * 3 / 4;
  Nanos stamp = this->now;
  for (int i = 1; i <= 20; ++i) {
    stamp += 10 * kMs;
    this->now = stamp + (i % 2 == 0 ? jitter : 0);  // every other command delivered late
    this->ecu_ok();
    auto c = this->cmd(true);
    c.stamp = stamp;
    for (std::size_t a = 0; a < s::kAxes; ++a) {
      const auto axis = static_cast<s::Axis>(a);
      s::set_axis_value(c, axis, s::axis_value(start, axis) + 0.9 * lim[axis].max_rate * 0.010 * i);
    }
    this->core.on_command(c, this->now);
    const auto d = this->core.tick(this->now);
    ASSERT_TRUE(d.active) << i;
    for (std::size_t a = 0; a < s::kAxes; ++a) {
      const auto axis = static_cast<s::Axis>(a);
      EXPECT_DOUBLE_EQ(s::axis_value(d.command, axis), s::axis_value(c, axis)) << s::to_string(axis) << " at " << i;
    }
  }
  EXPECT_EQ(this->core.counters().clamped, 0U);
  EXPECT_EQ(this->core.counters().rejected, 0U);
}

TEST(LimitChecker, TablesAreSane) {
  for (const auto* v : s::kVehicles) {
    SCOPED_TRACE(std::string(v->name));
    EXPECT_EQ(s::find_vehicle(v->name), v);
    for (const auto& a : v->axes) {
      EXPECT_LT(a.min, a.max);
      EXPECT_GE(a.max_rate, 0.0);
    }
    EXPECT_GE((*v)[s::Axis::throttle].min, 0.0);
    EXPECT_LE((*v)[s::Axis::throttle].max, 1.0);
    EXPECT_LE((*v)[s::Axis::accel].min, 0.0);
  }
  EXPECT_EQ(s::find_vehicle("nope"), nullptr);
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
  EXPECT_EQ(r.violations[0].axis, s::Axis::accel);
  EXPECT_TRUE(r.violations[0].rate);
  EXPECT_NEAR(r.applied.accel, 0.5, 1e-12);
  EXPECT_FALSE(r.rejected());
}

}  // namespace
