// The safety core with a fake clock: every transition and every fault, run by every vehicle's limit
// table through one typed suite (opendbc style), plus the generic limit checker.
#include <gtest/gtest.h>

#include <algorithm>
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
 public:
  // The wheel stands where the commands below ask it to be: engaging needs no step (a table that
  // rejects rate violations refuses to jump from the measured angle).
  SafetySuite() { core.on_measured(0.1 * V::limits[s::Axis::steering_angle].max, 0.0); }
  s::SafetyConfig cfg() {
    s::SafetyConfig c;
    c.limits = V::limits;
    return c;
  }
  s::SafetyCore core{cfg()};
  Nanos now = 1'000'000'000'000;  // the bridge's monotonic clock
  Nanos offset = 7'000'000'000;   // vehicle time - monotonic time (stepped by clock corrections)
  std::uint64_t seq = 0;

  Nanos vnow() const { return now + offset; }
  s::Command cmd(bool enable, s::WriterId writer = 0) {
    s::Command c;
    c.stamp = vnow();
    c.seq = ++seq;
    c.writer = writer;
    c.enable = enable;
    c.steering_angle = 0.1 * V::limits[s::Axis::steering_angle].max;
    c.throttle = 0.1;
    return c;
  }
  void send(const s::Command& c) { core.on_command(c, now, vnow()); }
  void ecu_ok() { core.on_ecu_status({true, false, false, false, 0}, now); }
  void step(Nanos dt) { now += dt; }
  // Steady 10 ms cycle: ECU status + command.
  void cycle(bool enable) {
    step(10 * kMs);
    ecu_ok();
    send(cmd(enable));
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
  // Enable held from the first command is no edge: a bridge (re)started under a publisher that
  // holds enable stays disengaged.
  for (int i = 0; i < 5; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->cycle(false);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  EXPECT_EQ(this->last_transition_reason(), s::Reason::enabled);
  const auto d = this->core.tick(this->now);
  EXPECT_TRUE(d.active);
  // Ramped from the measured state (pedals released) at the table's slew over one 10 ms period.
  EXPECT_DOUBLE_EQ(d.command.throttle, std::min(0.1, TypeParam::limits[s::Axis::throttle].max_rate * 0.010));
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
  this->send(this->cmd(false));
  this->step(1 * kMs);
  this->send(this->cmd(true));
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
  this->send(this->cmd(false));
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  ev = this->core.take_events();
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.back().reason, s::Reason::ecu_not_ready);
}

TYPED_TEST(SafetySuite, RefusesDuringOverrideOrFault) {
  this->cycle(false);
  this->core.on_ecu_status({true, false, true, false, 0}, this->now);
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.take_events().back().reason, s::Reason::driver_override);
  this->step(1 * kMs);
  this->send(this->cmd(false));
  this->core.on_ecu_status({true, false, false, true, 7}, this->now);
  this->step(1 * kMs);
  this->send(this->cmd(true));
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
  old.stamp = this->vnow() - 150 * kMs;
  this->send(old);
  EXPECT_EQ(this->core.counters().ignored_stale, 1U);
  auto replay = this->cmd(true);
  replay.seq = 1;
  this->send(replay);
  EXPECT_EQ(this->core.counters().ignored_sequence, 1U);
  this->step(1 * kMs);
  auto repeated = this->cmd(true);
  repeated.seq = this->seq - 3;  // the seq of the last accepted command (before old, replay), again
  this->send(repeated);
  EXPECT_EQ(this->core.counters().ignored_sequence, 2U);
  auto future = this->cmd(true);
  future.stamp = this->vnow() + 50 * kMs;
  this->send(future);
  EXPECT_EQ(this->core.counters().ignored_stale, 2U);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

TYPED_TEST(SafetySuite, EcuStatusTimeout) {
  this->engage();
  for (int i = 0; i < 10; ++i) {
    this->step(10 * kMs);
    this->send(this->cmd(true));
    this->core.tick(this->now);
  }
  EXPECT_EQ(this->core.state(), s::State::engaged);
  this->step(2 * kMs);
  this->send(this->cmd(true));
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
  EXPECT_EQ(this->core.e2e_error_level(), 0);
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
    c.stamp = this->vnow();
    // Far beyond the range: both range and (for engaged) rate are violated.
    s::set_axis_value(c, axis, lim[axis].max + 10.0);
    this->send(c);
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
  const auto& lim = TypeParam::limits;
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
    EXPECT_EQ(this->core.state(), s::State::engaged);
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
    c.stamp = this->vnow() + this->core.config().max_future_ns - 1 * kMs;
    s::set_axis_value(c, axis, before + lim[axis].max_rate * 0.010);
    this->send(c);
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
  // Throttle and brake ramp in separate runs: together the pedal interlock would cut the throttle.
  for (const auto skip : {s::Axis::brake, s::Axis::throttle}) {
    SCOPED_TRACE(std::string("without ") + std::string(s::to_string(skip)));
    this->engage();
    for (int i = 0; i < 20 && skip == s::Axis::throttle; ++i) {  // release the throttle first
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

// ---- time: timeouts on the bridge's monotonic clock, stamps only checked for plausibility -----

// Ticks every millisecond with the ECU fresh until the core stops sending the command; returns how
// long after `from` (monotonic) that happened. `feed` is called every 10 ms (e.g. ignored commands).
template <class Suite, class F>
Nanos ms_until_neutral(Suite* t, Nanos from, F feed) {
  for (int i = 1; i <= 2000; ++i) {
    t->step(1 * kMs);
    if (i % 10 == 0) {
      t->ecu_ok();
      feed();
    }
    if (!t->core.tick(t->now).active) return t->now - from;
  }
  return -1;
}

TYPED_TEST(SafetySuite, VehicleClockStepBackNeverExtendsTheActiveCommand) {
  this->engage();
  const Nanos last_rx = this->now;
  this->offset -= 5'000'000'000;  // PTP/NTP steps the vehicle clock 5 s back
  // The sender keeps going with its (now earlier) stamps: ignored, and they must not keep it alive.
  const Nanos t = ms_until_neutral(this, last_rx, [this] { this->send(this->cmd(true)); });
  EXPECT_GT(t, this->core.config().command_timeout_ns);
  EXPECT_LE(t, this->core.config().command_timeout_ns + 10 * kMs);
  EXPECT_EQ(this->core.reason(), s::Reason::command_timeout);
  EXPECT_GT(this->core.counters().ignored_stamp, 0U);
}

TYPED_TEST(SafetySuite, VehicleClockStepForwardKeepsValidCommandsAndTheTimeout) {
  this->engage();
  this->offset += 5'000'000'000;  // sender and bridge share the stepped clock
  for (int i = 0; i < 20; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  const Nanos last_rx = this->now;
  const Nanos t = ms_until_neutral(this, last_rx, [] {});
  EXPECT_GT(t, this->core.config().command_timeout_ns);
  EXPECT_LE(t, this->core.config().command_timeout_ns + 1 * kMs);
}

TYPED_TEST(SafetySuite, FutureStampsNeverExtendFreshness) {
  this->engage();
  this->step(10 * kMs);
  this->ecu_ok();
  auto c = this->cmd(true);
  c.stamp = this->vnow() + this->core.config().max_future_ns;  // the most a stamp may lead: accepted
  this->send(c);
  const auto accepted = this->core.counters().ignored_stale;
  const Nanos t = ms_until_neutral(this, this->now, [] {});
  EXPECT_EQ(this->core.counters().ignored_stale, accepted);
  EXPECT_GT(t, this->core.config().command_timeout_ns);
  EXPECT_LE(t, this->core.config().command_timeout_ns + 1 * kMs) << "timeout ran from the stamp, not from receipt";
}

TYPED_TEST(SafetySuite, OneSendersShiftedClockMakesItsCommandsImplausibleNotItsDisable) {
  this->engage();
  // Writer 2's clock runs 3 s behind: its stamps look stale, its disable still counts.
  this->step(5 * kMs);
  auto late = this->cmd(true, 2);
  late.stamp = this->vnow() - 3'000'000'000;
  this->send(late);
  EXPECT_EQ(this->core.state(), s::State::engaged);
  EXPECT_EQ(this->core.counters().ignored_stale, 1U);
  auto off = this->cmd(false, 2);
  off.stamp = this->vnow() - 3'000'000'000;
  this->send(off);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::enable_released);
  EXPECT_FALSE(this->core.tick(this->now).active);
}

// ---- writers ------------------------------------------------------------------------------

TYPED_TEST(SafetySuite, DisableFromAnyWriterWhateverItsSequence) {
  this->seq = 1'000'000;  // writer 0 publishes high sequence numbers
  this->engage();
  this->step(3 * kMs);
  auto off = this->cmd(false, 7);
  off.seq = 1;  // a second publisher (teleop, safety node) with its own low sequence
  this->send(off);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::enable_released);
  // And the first writer holding enable does not re-engage: every writer needs a new edge.
  for (int i = 0; i < 5; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
}

TYPED_TEST(SafetySuite, OnlyTheEngagingWriterDrivesTheActuators) {
  this->engage();
  // Writer 5 releases (any disable counts), the owner engages again, then writer 5 shows its
  // rising edge with the brake: ignored, never applied, the owner keeps the engagement.
  this->step(2 * kMs);
  this->send(this->cmd(false, 5));
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->engage();
  const auto before = this->core.counters().ignored_writer;
  for (int i = 0; i < 3; ++i) {
    this->step(3 * kMs);
    auto c = this->cmd(true, 5);
    c.throttle = 0.0;
    c.brake = 0.5;
    this->send(c);
  }
  EXPECT_EQ(this->core.counters().ignored_writer, before + 3);
  EXPECT_EQ(this->core.owner(), 0U);
  const auto d = this->core.tick(this->now);
  ASSERT_TRUE(d.active);
  EXPECT_DOUBLE_EQ(d.command.brake, 0.0);
  EXPECT_GT(d.command.throttle, 0.0);
}

TYPED_TEST(SafetySuite, RestartedPublisherWithANewHandleIsNotBlockedByTheOldSequence) {
  this->seq = 5'000;
  this->engage();
  // The planner restarts: new writer, seq from 1. Its first enable is no edge.
  this->seq = 0;
  this->cycle(false);
  EXPECT_EQ(this->core.state(), s::State::disengaged);  // its disable counted, seq 1 or not
  this->seq = 0;
  for (int i = 0; i < 3; ++i) {
    this->step(10 * kMs);
    this->ecu_ok();
    this->send(this->cmd(i > 0, 9));
  }
  EXPECT_EQ(this->core.state(), s::State::engaged);
  EXPECT_EQ(this->core.owner(), 9U);
  // Only the old handle's low-seq disable was out of sequence (and it still disengaged).
  EXPECT_EQ(this->core.counters().ignored_sequence, 1U);
}

TYPED_TEST(SafetySuite, ForgottenWritersMustShowANewEdge) {
  this->ecu_ok();
  this->send(this->cmd(false, 1));  // writer 1 armed ...
  for (s::WriterId w = 100; w < 100 + s::SafetyCore::kMaxWriters; ++w) {
    this->step(1 * kMs);
    this->send(this->cmd(false, w));  // ... then pushed out of the table by newer writers
  }
  this->step(1 * kMs);
  this->send(this->cmd(true, 1));
  EXPECT_EQ(this->core.state(), s::State::disengaged);
}

// ---- engagement from the measured state, pedal interlock, lateral limit --------------------

TYPED_TEST(SafetySuite, EngagementRampsFromTheMeasuredSteeringAngle) {
  const auto& lim = TypeParam::limits[s::Axis::steering_angle];
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
    if (lim.action == s::LimitAction::reject) {
      EXPECT_EQ(this->core.state(), s::State::disengaged) << "a step from the measured angle is rejected";
      const auto ev = this->core.take_events();
      ASSERT_FALSE(ev.empty());
      EXPECT_EQ(ev.back().kind, s::EventKind::limit);
      EXPECT_TRUE(ev.back().violation.rejected);
      EXPECT_TRUE(ev.back().violation.rate);
      continue;
    }
    ASSERT_EQ(this->core.state(), s::State::engaged);
    const auto d = this->core.tick(this->now);
    ASSERT_TRUE(d.active);
    EXPECT_LE(std::fabs(d.command.steering_angle - measured), lim.max_rate * 0.010 * (1 + 1e-9));
    EXPECT_DOUBLE_EQ(d.command.throttle, 0.0) << "throttle with the brake requested";
    EXPECT_LE(d.command.brake, TypeParam::limits[s::Axis::brake].max_rate * 0.010 * (1 + 1e-9));
    this->cycle(false);
  }
}

TYPED_TEST(SafetySuite, ThrottleIsZeroWhileTheBrakeIsRequested) {
  this->engage();
  const double cutoff = TypeParam::limits.brake_throttle_cutoff;
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
  const auto& v = TypeParam::limits;
  const auto& lim = v[s::Axis::steering_angle];
  this->engage();
  // Steers toward `target` within the rate limit (a table may reject faster requests); returns the
  // last applied angle.
  auto steer_toward = [this, &lim](double target, double speed, int steps) {
    double applied = this->core.tick(this->now).command.steering_angle;
    for (int i = 0; i < steps; ++i) {
      this->step(10 * kMs);
      this->ecu_ok();
      auto c = this->cmd(true);
      const double max_step = 0.9 * lim.max_rate * 0.010;
      c.steering_angle = applied + std::clamp(target - applied, -max_step, max_step);
      this->send(c);
      EXPECT_EQ(this->core.state(), s::State::engaged);
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

// ---- E2E, shutdown, bounded buffers -------------------------------------------------------

TYPED_TEST(SafetySuite, E2eErrorLevelSaturates) {
  this->engage();
  for (int i = 0; i < 2000; ++i) this->core.on_e2e(false, this->now);
  const int max = s::e2e_level_max(this->core.config());
  EXPECT_EQ(this->core.e2e_error_level(), max);
  EXPECT_GT(max, this->core.config().e2e_tolerance);
  for (int i = 0; i < max - this->core.config().e2e_tolerance; ++i) this->core.on_e2e(true, this->now);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged) << "2000 bad frames must not need 2000 good ones";
}

TYPED_TEST(SafetySuite, ShutdownDisengagesForGood) {
  this->engage();
  this->core.shutdown(this->now);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::shutdown);
  EXPECT_FALSE(this->core.tick(this->now).active);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::disengaged);
}

TYPED_TEST(SafetySuite, EventBufferIsBoundedAndCountsWhatItDrops) {
  this->core.clear_events();
  auto c = this->cmd(false);
  this->send(c);
  for (int i = 0; i < 1000; ++i) this->send(c);  // replays: one ignored event each
  EXPECT_EQ(this->core.events().size(), s::SafetyCore::kMaxEvents);
  EXPECT_EQ(this->core.counters().events_dropped, 1000U - s::SafetyCore::kMaxEvents);
  this->core.clear_events();
  EXPECT_TRUE(this->core.events().empty());
}

TYPED_TEST(SafetySuite, AnEdgeStartedBeforeADisengageDoesNotCount) {
  this->ecu_ok();
  this->send(this->cmd(false, 3));  // writer 3 released before ...
  this->engage();                   // ... writer 0 engages ...
  this->step(10 * kMs);
  this->core.on_ecu_status({true, true, true, false, 0}, this->now);  // ... and the driver overrides
  ASSERT_EQ(this->core.reason(), s::Reason::driver_override);
  this->cycle(false);  // writer 0 releases (override over)
  this->step(5 * kMs);
  this->send(this->cmd(true, 3));  // writer 3's "edge" began before the disengage: no engagement
  EXPECT_EQ(this->core.state(), s::State::disengaged);
}

TYPED_TEST(SafetySuite, UnmeasuredValuesKeepTheLastMeasurement) {
  const auto& lim = TypeParam::limits[s::Axis::steering_angle];
  const double measured = 0.5 * lim.max;
  this->core.on_measured(measured, 0.0);
  this->core.on_measured(std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN());
  this->cycle(false);
  this->step(10 * kMs);
  this->ecu_ok();
  auto c = this->cmd(true);
  c.steering_angle = measured + 3 * lim.max_rate * 0.010;  // three steps from the kept measurement
  this->send(c);
  if (lim.action == s::LimitAction::reject) {
    EXPECT_EQ(this->core.state(), s::State::disengaged);
    return;
  }
  ASSERT_EQ(this->core.state(), s::State::engaged);
  EXPECT_NEAR(this->core.tick(this->now).command.steering_angle, measured + lim.max_rate * 0.010, 1e-9);
}

TYPED_TEST(SafetySuite, ARejectedEnableIsNoHalfOfAnEdge) {
  this->cycle(false);
  this->step(10 * kMs);
  auto bad = this->cmd(true);
  bad.throttle = std::numeric_limits<double>::quiet_NaN();
  this->send(bad);  // rejected while disengaged
  EXPECT_EQ(this->core.counters().rejected, 1U);
  this->cycle(true);  // valid, enable still true: not an edge
  EXPECT_EQ(this->core.state(), s::State::disengaged);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::engaged);
}

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
    EXPECT_GE((*v)[s::Axis::throttle].min, 0.0);
    EXPECT_LE((*v)[s::Axis::throttle].max, 1.0);
    EXPECT_LE((*v)[s::Axis::accel].min, 0.0);
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
        EXPECT_EQ(r.violations[0].rejected, lim.action == s::LimitAction::reject);
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
  EXPECT_EQ(r.violations[0].axis, s::Axis::accel);
  EXPECT_TRUE(r.violations[0].rate);
  EXPECT_NEAR(r.applied.accel, 0.5, 1e-12);
  EXPECT_FALSE(r.rejected());
}

}  // namespace
