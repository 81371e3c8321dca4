// rig/time: HostTimeNode runs a real pmc process (here: scripts standing in for linuxptp's pmc,
// replaying recorded TIME_STATUS_NP output, hanging, failing) and reports the PU clock's state.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <map>
#include <string>

#include "host_time_node.hpp"
#include "rig_process.hpp"
#include "wait.hpp"

namespace sensor_rig::rig {
namespace {

std::map<std::string, std::string> values_of(const dds::DriverStatus& s) {
  return {s.values.begin(), s.values.end()};
}

class HostTime : public ::testing::Test {
 protected:
  test::TempDir dir_;

  std::string script(const std::string& name, const std::string& body) {
    auto path = (dir_.path / name).string();
    std::ofstream(path) << "#!/bin/sh\n" << body;
    ::chmod(path.c_str(), 0755);
    return path;
  }

  // Polls fast; returns the rig/time status once pmc has run `polls` times.
  static dds::DriverStatus status_after(HostTimeNode& node, int polls = 1) {
    dds::DriverStatus out;
    EXPECT_TRUE(test::wait_for(
        [&] {
          std::vector<dds::DriverStatus> st;
          node.supervise(st);
          out = st.at(0);
          return std::stoi(values_of(out).at("pmc_polls")) >= polls;
        },
        5000, 20));
    return out;
  }
};

constexpr const char* kSynchronized =
    "echo 'sending: GET TIME_STATUS_NP'\n"
    "printf '\\t90e2ba.fffe.20c7f8-0 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP \\n'\n"
    "printf '\\t\\tmaster_offset              -37\\n\\t\\tingress_time               1795255200034372012\\n'\n"
    "printf '\\t\\tcumulativeScaledRateOffset +0.000012345\\n\\t\\tscaledLastGmPhaseChange    0\\n'\n"
    "printf '\\t\\tgmTimeBaseIndicator        0\\n\\t\\tlastGmPhaseChange          0x0000'\"'\"'0000000000000000.0000\\n'\n"
    "printf '\\t\\tgmPresent                  true\\n\\t\\tgmIdentity                 0050c2.fffe.d0d000\\n'\n";

TEST_F(HostTime, SynchronizedFromRecordedPmcOutput) {
  HostTimeNode node({.pmc = script("pmc", kSynchronized), .poll_period_ms = 50});
  node.start();
  const auto s = status_after(node);
  EXPECT_EQ(s.name, "rig/time");
  EXPECT_EQ(s.level, dds::Level::kOk) << s.message;
  const auto v = values_of(s);
  EXPECT_EQ(v.at("ptp_state"), "synchronized");
  EXPECT_EQ(v.at("master_offset_ns"), "-37");
  EXPECT_EQ(v.at("grandmaster"), "0050c2.fffe.d0d000");
  EXPECT_EQ(v.at("realtime_steps"), "0");
}

TEST_F(HostTime, NoLinuxptpIsNotSynchronizedAndSaysWhy) {
  HostTimeNode node({.pmc = (dir_.path / "no-such-pmc").string(), .poll_period_ms = 50});
  node.start();
  const auto s = status_after(node);
  EXPECT_EQ(s.level, dds::Level::kWarn);
  EXPECT_EQ(values_of(s).at("ptp_state"), "not synchronized");
  EXPECT_NE(s.message.find("not found"), std::string::npos) << s.message;
}

TEST_F(HostTime, Ptp4lNotRunningIsNotSynchronized) {
  HostTimeNode node({.pmc = script("pmc", "echo 'sending: GET TIME_STATUS_NP'\n"), .poll_period_ms = 50});
  node.start();
  const auto s = status_after(node);
  EXPECT_EQ(values_of(s).at("ptp_state"), "not synchronized");
  EXPECT_NE(s.message.find("ptp4l not running"), std::string::npos) << s.message;
}

TEST_F(HostTime, AHungPmcIsKilledAndTheNodeStopsPromptly) {
  HostTimeNode node({.pmc = script("pmc", "sleep 30\n"), .poll_period_ms = 50, .pmc_timeout_ms = 300});
  node.start();
  const auto s = status_after(node);
  EXPECT_EQ(values_of(s).at("ptp_state"), "not synchronized");
  EXPECT_NE(s.message.find("did not answer"), std::string::npos) << s.message;
  const Nanos t0 = monotonic_now_ns();
  node.stop();
  EXPECT_LT(monotonic_now_ns() - t0, 3'000'000'000);  // at most one pmc timeout plus its kill grace
}

TEST_F(HostTime, GarbageOutputIsAnError) {
  HostTimeNode node({.pmc = script("pmc", "echo 'sending: GET TIME_STATUS_NP'\n"
                                          "printf '\\tx seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP\\n\\t\\tmaster_offset zz\\n'\n"),
                     .poll_period_ms = 50});
  node.start();
  const auto s = status_after(node);
  EXPECT_EQ(s.level, dds::Level::kError);
  EXPECT_EQ(values_of(s).at("ptp_state"), "error");
}

TEST_F(HostTime, StatusBeforeTheFirstPollIsStale) {
  HostTimeNode node({.pmc = script("pmc", "sleep 30\n"), .pmc_timeout_ms = 2000});
  node.start();
  std::vector<dds::DriverStatus> st;
  node.supervise(st);
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0].level, dds::Level::kStale);
  EXPECT_EQ(values_of(st[0]).at("ptp_state"), "unknown");
}

TEST(PmcProgram, EnvironmentOverridesTheDefault) {
  ::setenv("RIG_PMC", "/opt/linuxptp/pmc", 1);
  EXPECT_EQ(pmc_program(), "/opt/linuxptp/pmc");
  ::unsetenv("RIG_PMC");
  EXPECT_EQ(pmc_program(), "pmc");
}

}  // namespace
}  // namespace sensor_rig::rig
