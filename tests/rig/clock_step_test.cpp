// host.clock_step: CLOCK_REALTIME really stepped (root only) and stepped back, and a campaign killed
// while its step stood has the step undone by the next one. The host's clock ends as it began: the
// realtime - monotonic offset is measured before and after, within a millisecond.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "clock_step.hpp"
#include "rig_process.hpp"

namespace sensor_rig::rig {
namespace {

Nanos offset_ns() { return clock_pair_now().vehicle_minus_monotonic(); }

class ClockStepTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const auto why = ClockStep::not_permitted(); !why.empty()) GTEST_SKIP() << why;
    ::setenv("RIG_STATE_DIR", (dir_.path / "state").c_str(), 1);
    before_ = offset_ns();
  }
  void TearDown() override {
    if (!IsSkipped()) {
      EXPECT_NEAR(static_cast<double>(offset_ns() - before_), 0.0, 1e6) << "the host's clock as it was";
    }
    ::unsetenv("RIG_STATE_DIR");
  }
  test::TempDir dir_;
  Nanos before_ = 0;
};

TEST_F(ClockStepTest, StepsAndStepsBack) {
  {
    ClockStep step(-300'000'000);
    EXPECT_NEAR(static_cast<double>(offset_ns() - before_), -3e8, 1e6);
    EXPECT_FALSE(std::filesystem::is_empty(dir_.path / "state")) << "recorded while it stands";
  }
  EXPECT_FALSE(std::filesystem::exists(dir_.path / "state")) << "record gone";
}

TEST_F(ClockStepTest, AStepLeftByAKilledCampaignIsUndoneByTheNext) {
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  if (child == 0) {
    ClockStep step(400'000'000);  // killed before it can step back
    char c = 1;
    (void)!::write(ready[1], &c, 1);
    ::pause();
    std::_Exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  ::close(ready[0]);
  ::close(ready[1]);
  EXPECT_NEAR(static_cast<double>(offset_ns() - before_), 4e8, 1e6) << "the killed campaign's step stands";
  const auto undone = ClockStep::sweep();
  ASSERT_EQ(undone.size(), 1u);
  EXPECT_NE(undone[0].find("back by 400 ms"), std::string::npos) << undone[0];
  EXPECT_TRUE(ClockStep::sweep().empty()) << "once";
}

}  // namespace
}  // namespace sensor_rig::rig
