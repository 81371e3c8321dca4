#include "sensor_rig/timesync/host_clock.hpp"

#include <gtest/gtest.h>

#include "test_instants.hpp"

namespace sensor_rig::timesync {
namespace {
using test::kHour10;

// An injectable host: monotonic advances steadily, realtime slews (200 ppm) and is stepped twice.
TEST(RealtimeStepDetector, CountsStepsNotSlew) {
  RealtimeStepDetector d(1'000'000);
  Nanos rt = kHour10, mono = 5'000'000'000;
  std::vector<Nanos> seen;
  for (int i = 0; i < 100; ++i) {
    mono += 100'000'000;
    rt += 100'000'000 + 20'000;  // +200 ppm slew: no step
    if (i == 30) rt += 37'000'000'000;  // NTP step forward 37 s
    if (i == 60) rt -= 2'500'000;       // PTP step back 2.5 ms
    if (const Nanos s = d.observe(rt, mono); s != 0) seen.push_back(s);
  }
  EXPECT_EQ(d.steps(), 2u);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], 37'000'000'000 + 20'000);
  EXPECT_EQ(seen[1], -2'500'000 + 20'000);
  EXPECT_EQ(d.last_step_ns(), seen[1]);
  EXPECT_EQ(d.total_step_ns(), seen[0] + seen[1]);
}

TEST(HostSyncStatus, AbsentPtpIsNotSynchronized) {
  EXPECT_EQ(host_sync_status(false, "").state, HostSyncState::kNotSynchronized);
  const auto h = host_sync_status(true, "sending: GET TIME_STATUS_NP\n");
  EXPECT_EQ(h.state, HostSyncState::kNotSynchronized);
  EXPECT_NE(h.reason.find("ptp4l not running"), std::string::npos);
  EXPECT_STREQ(to_string(h.state), "not synchronized");
}

std::string response(const char* offset, const char* gm_present) {
  return std::string("sending: GET TIME_STATUS_NP\n\t90e2ba.fffe.20c7f8-0 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP \n") +
         "\t\tmaster_offset              " + offset + "\n\t\tingress_time               1795255200034372012\n"
         "\t\tcumulativeScaledRateOffset +0.000012345\n\t\tscaledLastGmPhaseChange    0\n"
         "\t\tgmTimeBaseIndicator        0\n\t\tlastGmPhaseChange          0x0000'0000000000000000.0000\n"
         "\t\tgmPresent                  " + gm_present + "\n\t\tgmIdentity                 0050c2.fffe.d0d000\n";
}

TEST(HostSyncStatus, FromRecordedPmcOutput) {
  const auto ok = host_sync_status(true, response("-37", "true"));
  EXPECT_EQ(ok.state, HostSyncState::kSynchronized);
  EXPECT_EQ(ok.master_offset_ns, -37);
  EXPECT_EQ(ok.gm_identity, "0050c2.fffe.d0d000");
  EXPECT_EQ(host_sync_status(true, response("5000", "true")).state, HostSyncState::kUnsynchronized);
  EXPECT_EQ(host_sync_status(true, response("0", "false")).state, HostSyncState::kUnsynchronized);
  EXPECT_EQ(host_sync_status(true, response("zz", "true")).state, HostSyncState::kError);
}

}  // namespace
}  // namespace sensor_rig::timesync
