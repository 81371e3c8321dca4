// SafetySuite, the state machine: engagement only on a rising enable edge with everything fresh
// (an edge begun before a disengage, or a rejected enable, is no edge), refusals (no ECU status, not
// ready, override, fault) and every disengage reason: enable released, command and ECU status
// timeouts, E2E errors, driver override, ECU fault, bus-off.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TYPED_TEST(SafetySuite, EngagesOnlyOnEnableEdgeWithEverythingFresh) {
  this->ecu_ok();
  // Enable held from the first command is no edge: a bridge (re)started under a publisher that
  // holds enable stays disengaged.
  for (int i = 0; i < 5; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->cycle(false);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
  EXPECT_EQ(this->last_transition_reason(), s::Reason::kEnabled);
  const auto d = this->core.tick(this->now);
  EXPECT_TRUE(d.active);
  // Ramped from the measured state (pedals released) at the table's slew over one 10 ms period.
  EXPECT_DOUBLE_EQ(d.command.throttle, std::min(0.1, TypeParam::kLimits[s::Axis::kThrottle].max_rate * 0.010));
}

TYPED_TEST(SafetySuite, EnableHeldAfterDisengageDoesNotReengage) {
  this->engage();
  this->cycle(false);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->last_transition_reason(), s::Reason::kEnableReleased);
  EXPECT_FALSE(this->core.tick(this->now).active);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

TYPED_TEST(SafetySuite, RefusesWithoutEcuStatusOrWhenNotReady) {
  this->send(this->cmd(false));
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  auto ev = this->core.take_events();
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.back().kind, s::EventKind::kEngageRefused);
  EXPECT_EQ(ev.back().reason, s::Reason::kEcuTimeout);
  // The edge is consumed: a ready ECU later does not engage while enable stays true.
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->step(10 * kMs);
  this->core.on_ecu_status({false, false, false, false, 0}, this->now);
  this->send(this->cmd(false));
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  ev = this->core.take_events();
  ASSERT_FALSE(ev.empty());
  EXPECT_EQ(ev.back().reason, s::Reason::kEcuNotReady);
}

TYPED_TEST(SafetySuite, RefusesDuringOverrideOrFault) {
  this->cycle(false);
  this->core.on_ecu_status({true, false, true, false, 0}, this->now);
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.take_events().back().reason, s::Reason::kDriverOverride);
  this->step(1 * kMs);
  this->send(this->cmd(false));
  this->core.on_ecu_status({true, false, false, true, 7}, this->now);
  this->step(1 * kMs);
  this->send(this->cmd(true));
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.take_events().back().reason, s::Reason::kEcuFault);
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
  EXPECT_EQ(this->core.reason(), s::Reason::kCommandTimeout);
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
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

TYPED_TEST(SafetySuite, EcuStatusTimeout) {
  this->engage();
  for (int i = 0; i < 10; ++i) {
    this->step(10 * kMs);
    this->send(this->cmd(true));
    this->core.tick(this->now);
  }
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
  this->step(2 * kMs);
  this->send(this->cmd(true));
  EXPECT_FALSE(this->core.tick(this->now).active);
  EXPECT_EQ(this->core.reason(), s::Reason::kEcuTimeout);
}

TYPED_TEST(SafetySuite, E2eErrorsBeyondTolerance) {
  this->engage();
  const int tol = this->core.config().e2e_tolerance;
  for (int i = 0; i < tol; ++i) this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
  this->core.on_e2e(true, this->now);  // a good frame pays one back
  this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
  this->core.on_e2e(false, this->now);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::kE2eErrors);
  // Still beyond tolerance: a new edge is refused.
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  for (int i = 0; i < 10; ++i) this->core.on_e2e(true, this->now);
  EXPECT_EQ(this->core.e2e_error_level(), 0);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

TYPED_TEST(SafetySuite, DriverOverrideLatchedUntilNewEnable) {
  this->engage();
  this->step(10 * kMs);
  this->core.on_ecu_status({true, true, true, false, 0}, this->now);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::kDriverOverride);
  for (int i = 0; i < 5; ++i) this->cycle(true);  // override gone, enable held
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

TYPED_TEST(SafetySuite, EcuFaultAndNotReadyDisengage) {
  this->engage();
  this->core.on_ecu_status({true, true, false, true, 3}, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::kEcuFault);
  this->engage();
  this->core.on_ecu_status({false, true, false, false, 0}, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::kEcuNotReady);
}

TYPED_TEST(SafetySuite, BusOffDisengagesAndBlocksEngage) {
  this->engage();
  this->core.on_bus_state(true, this->now);
  EXPECT_EQ(this->core.reason(), s::Reason::kBusOff);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->core.on_bus_state(false, this->now);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

TYPED_TEST(SafetySuite, AnEdgeStartedBeforeADisengageDoesNotCount) {
  this->ecu_ok();
  this->send(this->cmd(false, 3));  // writer 3 released before ...
  this->engage();                   // ... writer 0 engages ...
  this->step(10 * kMs);
  this->core.on_ecu_status({true, true, true, false, 0}, this->now);  // ... and the driver overrides
  ASSERT_EQ(this->core.reason(), s::Reason::kDriverOverride);
  this->cycle(false);  // writer 0 releases (override over)
  this->step(5 * kMs);
  this->send(this->cmd(true, 3));  // writer 3's "edge" began before the disengage: no engagement
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
}

TYPED_TEST(SafetySuite, ARejectedEnableIsNoHalfOfAnEdge) {
  this->cycle(false);
  this->step(10 * kMs);
  auto bad = this->cmd(true);
  bad.throttle = std::numeric_limits<double>::quiet_NaN();
  this->send(bad);  // rejected while disengaged
  EXPECT_EQ(this->core.counters().rejected, 1U);
  this->cycle(true);  // valid, enable still true: not an edge
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
