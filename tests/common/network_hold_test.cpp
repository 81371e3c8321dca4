// host.network_delay held in a mock (common/network_hold.hpp): each datagram handed over while a
// delay lasts leaves ms ± jitter_ms later, never before one handed over earlier, and those after the
// delay queue behind the last held one; a plan's delays of a device, not netem's (device "lo").
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "sensor_rig/common/network_hold.hpp"

namespace sensor_rig::faults {
namespace {

constexpr Nanos kMs = 1'000'000;

TEST(NetworkHold, HoldsExactlyTheDelayInOrderAndQueuesWhatComesAfterBehindIt) {
  NetworkHold hold({NetworkHold::Window{7, 1000 * kMs, 2000 * kMs, 50 * kMs, 0}});
  EXPECT_EQ(hold.due(999 * kMs).at_mono, 999 * kMs);  // before: at once
  EXPECT_EQ(hold.due(999 * kMs).fault, 0u);
  Nanos last = 0;
  for (Nanos t = 1000 * kMs; t < 2000 * kMs; t += 10 * kMs) {
    const auto d = hold.due(t);
    EXPECT_EQ(d.at_mono, t + 50 * kMs);
    EXPECT_EQ(d.fault, 7u);
    EXPECT_GT(d.at_mono, last);
    last = d.at_mono;
  }
  // After it: behind the last held one (it leaves at 2040 ms), then at once.
  EXPECT_EQ(hold.due(2000 * kMs).at_mono, 2040 * kMs);
  EXPECT_EQ(hold.due(2000 * kMs).fault, 0u);
  EXPECT_EQ(hold.due(2030 * kMs).at_mono, 2040 * kMs);
  EXPECT_EQ(hold.due(2050 * kMs).at_mono, 2050 * kMs);
}

TEST(NetworkHold, AJitteredHoldStaysWithinItsRangeUsesItAndNeverReorders) {
  NetworkHold hold({NetworkHold::Window{3, 0, 10'000 * kMs, 30 * kMs, 10 * kMs}}, 42);
  std::vector<Nanos> holds;
  Nanos last = 0;
  for (Nanos t = 0; t < 10'000 * kMs; t += kMs) {  // 1 kHz for 10 s
    const auto d = hold.due(t);
    ASSERT_GE(d.at_mono, last) << "at " << t;
    last = d.at_mono;
    holds.push_back(d.at_mono - t);
  }
  const auto [lo, hi] = std::minmax_element(holds.begin(), holds.end());
  EXPECT_GE(*lo, 20 * kMs);
  EXPECT_LE(*hi, 40 * kMs);
  // Both outer quarters of the range are used (a hold pinned to its longest draw would not).
  EXPECT_LT(*lo, 25 * kMs);
  EXPECT_GT(*hi, 35 * kMs);
}

TEST(NetworkHold, APlansDelaysOfADeviceNotNetems) {
  Plan plan;
  plan.epoch_mono_ns = 5'000 * kMs;
  plan.events.push_back(FaultEvent{1, "host.network_delay", "", 2.0, 1.5, {{"ms", "40"}, {"jitter_ms", "5"}}});
  plan.events.push_back(FaultEvent{2, "host.network_delay", "lo", 4.0, 1.0, {{"ms", "40"}}});  // netem's
  plan.events.push_back(FaultEvent{3, "host.cpu_hog", "", 1.0, 1.0, {}});
  const auto w = NetworkHold::windows_of(plan, "paravan");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].id, 1u);
  EXPECT_EQ(w[0].from_mono, 7'000 * kMs);
  EXPECT_EQ(w[0].until_mono, 8'500 * kMs);
  EXPECT_EQ(w[0].delay_ns, 40 * kMs);
  EXPECT_EQ(w[0].jitter_ns, 5 * kMs);
}

}  // namespace
}  // namespace sensor_rig::faults
