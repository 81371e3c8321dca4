// SafetySuite, time: every timeout runs on the bridge's monotonic clock; a command's own stamp
// (vehicle time) is only checked for plausibility, so a step of the vehicle clock or a sender's
// shifted clock never keeps a command alive.
#include <gtest/gtest.h>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

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
  EXPECT_EQ(this->core.reason(), s::Reason::kCommandTimeout);
  EXPECT_GT(this->core.counters().ignored_stamp, 0U);
}

TYPED_TEST(SafetySuite, VehicleClockStepForwardKeepsValidCommandsAndTheTimeout) {
  this->engage();
  this->offset += 5'000'000'000;  // sender and bridge share the stepped clock
  for (int i = 0; i < 20; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
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
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
  EXPECT_EQ(this->core.counters().ignored_stale, 1U);
  auto off = this->cmd(false, 2);
  off.stamp = this->vnow() - 3'000'000'000;
  this->send(off);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::kEnableReleased);
  EXPECT_FALSE(this->core.tick(this->now).active);
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
