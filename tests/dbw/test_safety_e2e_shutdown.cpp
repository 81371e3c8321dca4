// SafetySuite, E2E, shutdown and bounded buffers: the E2E error level saturates (a long burst is
// paid back by a bounded number of good frames), shutdown disengages for good, the event buffer is
// bounded and counts what it drops.
#include <gtest/gtest.h>

#include "safety_fixture.hpp"

namespace sensor_rig::dbw::safety::test {
namespace {

TYPED_TEST(SafetySuite, E2eErrorLevelSaturates) {
  this->engage();
  for (int i = 0; i < 2000; ++i) this->core.on_e2e(false, this->now);
  const int max = s::e2e_level_max(this->core.config());
  EXPECT_EQ(this->core.e2e_error_level(), max);
  EXPECT_GT(max, this->core.config().e2e_tolerance);
  for (int i = 0; i < max - this->core.config().e2e_tolerance; ++i) this->core.on_e2e(true, this->now);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kEngaged) << "2000 bad frames must not need 2000 good ones";
}

TYPED_TEST(SafetySuite, ShutdownDisengagesForGood) {
  this->engage();
  this->core.shutdown(this->now);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
  EXPECT_EQ(this->core.reason(), s::Reason::kShutdown);
  EXPECT_FALSE(this->core.tick(this->now).active);
  this->cycle(false);
  this->cycle(true);
  EXPECT_EQ(this->core.state(), s::State::kDisengaged);
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

}  // namespace
}  // namespace sensor_rig::dbw::safety::test
