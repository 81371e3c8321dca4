// host.network_delay by netem on lo (rig/src/network_delay.hpp) against a stand-in `tc` ($RIG_TC)
// that keeps lo's qdiscs in a file: this CI kernel has no sch_netem, and a test must not shape the
// host's loopback under the other tests anyway. What the rig asks of tc, in order; that everything is
// removed when the fault ends and when tc refuses a step; that a campaign killed while its shaping
// stood leaves its record under $RIG_STATE_DIR, and the next sweep removes the qdisc; that a live
// campaign's shaping is left alone.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fake_tc.hpp"
#include "network_delay.hpp"
#include "rig_process.hpp"

namespace sensor_rig::rig {
namespace {

namespace fs = std::filesystem;


class NetworkDelay : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string tc = dir_.write("tc", test::kFakeTc);
    fs::permissions(tc, fs::perms::owner_all);
    state_ = dir_.path / "lo.state";
    log_ = dir_.path / "tc.log";
    state_dir_ = dir_.path / "run";
    ::setenv("RIG_TC", tc.c_str(), 1);
    ::setenv("RIG_STATE_DIR", state_dir_.c_str(), 1);
    ::setenv("FAKE_TC_STATE", state_.c_str(), 1);
    ::setenv("FAKE_TC_LOG", log_.c_str(), 1);
    ::unsetenv("FAKE_TC_NO_NETEM");
    ASSERT_EQ(LoopbackDelay::unavailable(), "");  // probed (once per process) on the stand-in
    fs::remove(log_);
  }
  void TearDown() override {
    ::unsetenv("RIG_TC");
    ::unsetenv("RIG_STATE_DIR");
  }
  std::vector<std::string> calls() const {
    std::vector<std::string> v;
    std::ifstream in(log_);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
  }
  std::size_t records() const {
    std::size_t n = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(state_dir_, ec))
      if (e.path().filename().string().rfind("net-delay-", 0) == 0) ++n;
    return n;
  }

  test::TempDir dir_;
  fs::path state_, log_, state_dir_;
};

TEST_F(NetworkDelay, ShapesTheRigsPortsAndRemovesEverythingWhenTheFaultEnds) {
  {
    LoopbackDelay d(50, 5, {2368, 8308});
    EXPECT_EQ(test::run("cat " + state_.string()).second,
              "qdisc netem 30: parent 1:3 delay 50.000ms 5.000ms\nfilter dport 2368 0xffff flowid 1:3\n"
              "filter dport 8308 0xffff flowid 1:3\n");
    EXPECT_EQ(records(), 1u) << "recorded before it was made";
  }
  EXPECT_FALSE(fs::exists(state_)) << "lo as before";
  EXPECT_EQ(records(), 0u);
  const std::vector<std::string> want{
      "qdisc add dev lo root handle 1: prio bands 3 priomap 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1",
      "qdisc add dev lo parent 1:3 handle 30: netem delay 50.000ms 5.000ms",
      "filter add dev lo parent 1: protocol ip prio 1 u32 match ip protocol 17 0xff match ip dport 2368 0xffff flowid 1:3",
      "filter add dev lo parent 1: protocol ip prio 1 u32 match ip protocol 17 0xff match ip dport 8308 0xffff flowid 1:3",
      "filter del dev lo parent 1: prio 1",  // new packets pass at once, the held ones leave
      "qdisc del dev lo root handle 1:"};
  EXPECT_EQ(calls(), want);
}

TEST_F(NetworkDelay, ARefusedStepLeavesNothing) {
  ::setenv("FAKE_TC_NO_NETEM", "1", 1);
  try {
    LoopbackDelay d(50, 0, {2368});
    ADD_FAILURE() << "shaped without netem";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Specified qdisc kind is unknown"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(state_));
  EXPECT_EQ(records(), 0u);
}

TEST_F(NetworkDelay, AKilledCampaignsShapingIsRemovedByTheNextSweepALiveOnesIsNot) {
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    LoopbackDelay d(50, 0, {2368});
    ::kill(::getpid(), SIGKILL);  // killed while the delay stands: no destructor
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  ASSERT_TRUE(fs::exists(state_)) << "the killed campaign's qdisc stands";
  EXPECT_EQ(records(), 1u);
  const auto lines = LoopbackDelay::sweep();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("removed the netem delay on lo"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find(std::to_string(child)), std::string::npos) << lines[0];
  EXPECT_FALSE(fs::exists(state_));
  EXPECT_EQ(records(), 0u);
  // This process's own shaping (a campaign still running) stays.
  LoopbackDelay mine(20, 0, {2368});
  EXPECT_TRUE(LoopbackDelay::sweep().empty());
  EXPECT_TRUE(fs::exists(state_));
}

}  // namespace
}  // namespace sensor_rig::rig
