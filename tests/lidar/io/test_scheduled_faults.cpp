// The scheduled network faults without sockets: host.network_delay's hold with jitter_ms (issue 25).
// What leaves (offsets, order, bytes) against what went in.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <utility>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/scheduled_faults.hpp"

namespace sensor_rig::lidar::mock {
namespace {
constexpr Nanos kGap = 663'000;  // a VLP-32C's data packets, ~1508 a second

struct Left {
  int id;
  Nanos in, out;
  std::vector<std::byte> bytes;
};

// Packets 0..n-1 pushed every kGap (tagged with their index, bytes all 0x11); what leaves, in order.
std::vector<Left> run(std::vector<NetFault> faults, int n, std::uint64_t seed = 1) {
  ScheduledFaults s(std::move(faults), seed);
  std::vector<Left> out;
  std::vector<Nanos> in_of(static_cast<std::size_t>(n));
  std::vector<std::byte> pkt(1206, std::byte{0x11});
  const auto take = [&](std::span<const NetPacket> left) {
    for (const NetPacket& p : left) {
      const int id = static_cast<int>(p.tag);
      out.push_back({id, in_of[static_cast<std::size_t>(id)], p.offset_ns, {p.bytes.begin(), p.bytes.end()}});
    }
  };
  for (int i = 0; i < n; ++i) {
    in_of[static_cast<std::size_t>(i)] = static_cast<Nanos>(i) * kGap;
    take(s.push(NetPacket{in_of[static_cast<std::size_t>(i)], pkt, false, i}));
  }
  take(s.flush());
  return out;
}

NetFault delay(Nanos from, Nanos until, Nanos ms, Nanos jitter) {
  NetFault f;
  f.id = 3;
  f.kind = NetFault::Kind::kDelay;
  f.from_ns = from;
  f.until_ns = until;
  f.delay_ns = ms;
  f.jitter_ns = jitter;
  return f;
}

// 30 ms ± 10 ms for 2 s: every held packet's hold within [20, 40] ms, the range really used (a
// quarter of it at either end each holds > 10 % of the packets; a fixed hold, the jitter ignored,
// has none there), and the packets leave in the order they came, never before an earlier one.
TEST(ScheduledFaults, AJitteredDelayHoldsEachPacketWithinTheRangeInOrder) {
  const Nanos from = 100 * kMs, until = 2'100 * kMs;
  const auto out = run({delay(from, until, 30 * kMs, 10 * kMs)}, 3'500);
  ASSERT_EQ(out.size(), 3'500u);
  std::vector<Nanos> holds;
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].id, static_cast<int>(i)) << "reordered";
    if (i > 0) {
      EXPECT_GE(out[i].out, out[i - 1].out) << "packet " << i << " due before the one ahead of it";
    }
    const Nanos hold = out[i].out - out[i].in;
    if (out[i].in < from) {
      EXPECT_EQ(hold, 0) << "packet " << i << " before the fault";
      continue;
    }
    if (out[i].in >= until) {  // after it: behind the held ones, then at once
      EXPECT_EQ(out[i].out, std::max(out[i].in, out[i - 1].out)) << "packet " << i << " after the fault";
      continue;
    }
    EXPECT_GE(hold, 20 * kMs) << "packet " << i;
    EXPECT_LE(hold, 40 * kMs) << "packet " << i;
    holds.push_back(hold);
  }
  ASSERT_GT(holds.size(), 2'900u);
  const auto share = [&](auto pred) { return static_cast<double>(std::count_if(holds.begin(), holds.end(), pred)) / static_cast<double>(holds.size()); };
  const double low = share([](Nanos h) { return h < 25 * kMs; }), high = share([](Nanos h) { return h > 35 * kMs; });
  EXPECT_GT(low, 0.10) << "holds < 25 ms";
  EXPECT_GT(high, 0.10) << "holds > 35 ms";
  std::sort(holds.begin(), holds.end());
  EXPECT_NEAR(static_cast<double>(holds[holds.size() / 2]) / kMs, 30.0, 4.0) << "median hold";
  std::printf("holds: min %.2f median %.2f max %.2f ms, < 25 ms %.1f %%, > 35 ms %.1f %%\n",
              static_cast<double>(holds.front()) / kMs, static_cast<double>(holds[holds.size() / 2]) / kMs,
              static_cast<double>(holds.back()) / kMs, 100 * low, 100 * high);
}

// Without jitter the hold is the delay exactly, as before (the packets after the fault leave behind
// the last held one); a jitter larger than the delay holds no packet less than 0 (it cannot leave
// before it exists).
TEST(ScheduledFaults, AnUnjitteredDelayHoldsEveryPacketExactlyAndNoHoldIsNegative) {
  const Nanos last_held_due = (1'000 * kMs / kGap) * kGap + 30 * kMs;
  for (const auto& p : run({delay(0, 1'000 * kMs, 30 * kMs, 0)}, 2'000))
    ASSERT_EQ(p.out, p.in < 1'000 * kMs ? p.in + 30 * kMs : std::max(p.in, last_held_due)) << "packet " << p.id;
  Nanos prev = 0;
  for (const auto& p : run({delay(0, 1'000 * kMs, 2 * kMs, 5 * kMs)}, 1'000)) {
    ASSERT_GE(p.out - p.in, 0) << "packet " << p.id;
    ASSERT_LE(p.out - p.in, 7 * kMs) << "packet " << p.id;
    ASSERT_GE(p.out, prev) << "packet " << p.id;
    prev = p.out;
  }
}

// The jitter draws from a generator of its own: for a seed, lidar.corrupt's random byte is the same
// whether a jittered delay runs beside it or not, and a seed gives the same holds every time.
TEST(ScheduledFaults, AJitterChangesNoOtherFaultsDrawsForASeed) {
  NetFault corrupt;
  corrupt.id = 4;
  corrupt.kind = NetFault::Kind::kCorrupt;
  corrupt.from_ns = 500 * kMs;
  corrupt.random_byte = true;
  const auto changed = [](const std::vector<Left>& out) {
    for (const auto& p : out)
      for (std::size_t k = 0; k < p.bytes.size(); ++k)
        if (p.bytes[k] != std::byte{0x11}) return std::pair<int, std::size_t>{p.id, k};
    return std::pair<int, std::size_t>{-1, 0};
  };
  const auto alone = changed(run({corrupt}, 1'500, 7));
  ASSERT_GE(alone.first, 0);
  const auto with_delay = run({delay(100 * kMs, 900 * kMs, 30 * kMs, 10 * kMs), corrupt}, 1'500, 7);
  EXPECT_EQ(changed(with_delay), alone);
  const auto again = run({delay(100 * kMs, 900 * kMs, 30 * kMs, 10 * kMs), corrupt}, 1'500, 7);
  ASSERT_EQ(again.size(), with_delay.size());
  for (std::size_t i = 0; i < again.size(); ++i) ASSERT_EQ(again[i].out, with_delay[i].out) << "packet " << i;
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
