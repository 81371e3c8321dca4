// SafetySuite, writers: any writer's disable counts whatever its sequence, only the engaging writer
// drives the actuators, a restarted publisher is not blocked by the old sequence, a forgotten writer
// must show a new edge.
#include <gtest/gtest.h>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TYPED_TEST(SafetySuite, DisableFromAnyWriterWhateverItsSequence) {
  this->seq = 1'000'000;  // writer 0 publishes high sequence numbers
  this->engage();
  this->step(3 * kMs);
  auto off = this->cmd(false, 7);
  off.seq = 1;  // a second publisher (teleop, safety node) with its own low sequence
  this->send(off);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::kEnableReleased);
  // And the first writer holding enable does not re-engage: every writer needs a new edge.
  for (int i = 0; i < 5; ++i) this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
}

TYPED_TEST(SafetySuite, OnlyTheEngagingWriterDrivesTheActuators) {
  this->engage();
  // Writer 5 releases (any disable counts), the owner engages again, then writer 5 shows its
  // rising edge with the brake: ignored, never applied, the owner keeps the engagement.
  this->step(2 * kMs);
  this->send(this->cmd(false, 5));
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
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
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);  // its disable counted, seq 1 or not
  this->seq = 0;
  for (int i = 0; i < 3; ++i) {
    this->step(10 * kMs);
    this->ecu_ok();
    this->send(this->cmd(i > 0, 9));
  }
  EXPECT_EQ(this->core.state(), s::State::kEngaged);
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
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
}

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
