// Fault injector without sockets: rates, reproducibility from the seed, what each fault does to
// the packet stream (order, content, schedule).
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <vector>

#include "sensor_rig/lidar/mock/fault_injector.hpp"

namespace sensor_rig::lidar::mock {
namespace {

struct Out {
  Nanos offset;
  std::vector<std::byte> bytes;
};

// Packet i: 1206 bytes, the first 4 holding i; sent at i ms.
std::vector<Out> run(const FaultConfig& cfg, int n, FaultStats* stats = nullptr) {
  FaultInjector fi(cfg);
  std::vector<Out> out;
  std::vector<std::byte> pkt(1206);
  for (int i = 0; i < n; ++i) {
    std::memcpy(pkt.data(), &i, sizeof i);
    for (const auto& f : fi.push(static_cast<Nanos>(i) * 1'000'000, pkt, false)) {
      out.push_back({f.offset_ns, {f.bytes.begin(), f.bytes.end()}});
    }
  }
  for (const auto& f : fi.flush()) out.push_back({f.offset_ns, {f.bytes.begin(), f.bytes.end()}});
  if (stats) *stats = fi.stats();
  return out;
}

int id_of(const Out& o) {
  int i = -1;
  if (o.bytes.size() >= sizeof i) std::memcpy(&i, o.bytes.data(), sizeof i);
  return i;
}

TEST(FaultInjector, NoFaultsPassesEverythingThrough) {
  FaultStats st;
  const auto out = run({}, 100, &st);
  ASSERT_EQ(out.size(), 100u);
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(id_of(out[static_cast<std::size_t>(i)]), i);
    EXPECT_EQ(out[static_cast<std::size_t>(i)].offset, static_cast<Nanos>(i) * 1'000'000);
  }
  EXPECT_EQ(st.dropped + st.corrupted + st.truncated + st.duplicated + st.reordered + st.stalls, 0u);
}

TEST(FaultInjector, DropRateAndSeedReproducibility) {
  FaultConfig c;
  c.drop_rate = 0.25;
  c.seed = 42;
  FaultStats a, b;
  const auto x = run(c, 4000, &a);
  const auto y = run(c, 4000, &b);
  EXPECT_EQ(x.size(), 4000u - a.dropped);
  EXPECT_NEAR(static_cast<double>(a.dropped) / 4000.0, 0.25, 0.03);
  ASSERT_EQ(x.size(), y.size());
  for (std::size_t i = 0; i < x.size(); ++i) ASSERT_EQ(id_of(x[i]), id_of(y[i]));
  c.seed = 43;
  FaultStats other;
  run(c, 4000, &other);
  EXPECT_NE(other.dropped, a.dropped) << "a different seed gives a different pattern";
}

TEST(FaultInjector, CorruptionFlipsBytesButKeepsSize) {
  FaultConfig c;
  c.corrupt_rate = 1.0;
  FaultStats st;
  const auto out = run(c, 50, &st);
  ASSERT_EQ(out.size(), 50u);
  EXPECT_EQ(st.corrupted, 50u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].bytes.size(), 1206u);
    std::vector<std::byte> orig(1206);
    const int id = static_cast<int>(i);
    std::memcpy(orig.data(), &id, sizeof id);
    std::size_t diff = 0;
    for (std::size_t k = 0; k < orig.size(); ++k) diff += orig[k] != out[i].bytes[k] ? 1 : 0;
    EXPECT_GE(diff, 1u);
    EXPECT_LE(diff, 4u);
  }
}

TEST(FaultInjector, TruncationShortensToAPrefix) {
  FaultConfig c;
  c.truncate_rate = 1.0;
  FaultStats st;
  const auto out = run(c, 200, &st);
  EXPECT_EQ(st.truncated, 200u);
  for (const auto& o : out) {
    EXPECT_GE(o.bytes.size(), 1u);
    EXPECT_LT(o.bytes.size(), 1206u);
  }
}

TEST(FaultInjector, DuplicatesFollowTheOriginal) {
  FaultConfig c;
  c.duplicate_rate = 0.3;
  FaultStats st;
  const auto out = run(c, 500, &st);
  EXPECT_EQ(out.size(), 500u + st.duplicated);
  std::size_t repeats = 0;
  for (std::size_t i = 1; i < out.size(); ++i) {
    ASSERT_GE(id_of(out[i]), id_of(out[i - 1]));
    repeats += id_of(out[i]) == id_of(out[i - 1]) ? 1 : 0;
  }
  EXPECT_EQ(repeats, st.duplicated);
}

TEST(FaultInjector, ReorderSwapsWithTheNextPacketAndKeepsAll) {
  FaultConfig c;
  c.reorder_rate = 0.2;
  FaultStats st;
  const auto out = run(c, 500, &st);
  ASSERT_EQ(out.size(), 500u);
  std::vector<int> seen(500, 0);
  std::size_t inversions = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    ++seen[static_cast<std::size_t>(id_of(out[i]))];
    if (i > 0 && id_of(out[i]) < id_of(out[i - 1])) {
      ++inversions;
      EXPECT_EQ(id_of(out[i]) + 1, id_of(out[i - 1])) << "held back by exactly one packet";
    }
    if (i > 0) {
      EXPECT_GE(out[i].offset, out[i - 1].offset) << "schedule stays monotonic";
    }
  }
  for (int s : seen) EXPECT_EQ(s, 1);
  EXPECT_GT(st.reordered, 50u);
  EXPECT_GE(inversions + 1, st.reordered);
  EXPECT_LE(inversions, st.reordered);
}

TEST(FaultInjector, StallsShiftTheScheduleOfEverythingAfter) {
  FaultConfig c;
  c.stall_ns = 30'000'000;
  c.stall_every_ns = 100'000'000;
  FaultStats st;
  const auto out = run(c, 350, &st);  // packets at 0..349 ms: stalls at 100, 200, 300 ms
  ASSERT_EQ(out.size(), 350u);
  EXPECT_EQ(st.stalls, 3u);
  EXPECT_EQ(st.stalled_ns, 90'000'000);
  EXPECT_EQ(out[99].offset, 99'000'000);
  EXPECT_EQ(out[100].offset, 130'000'000);
  EXPECT_EQ(out[349].offset, 349'000'000 + 90'000'000);
}

TEST(FaultInjector, EmptyAndTinyPacketsAreSafe) {
  FaultConfig c;
  c.corrupt_rate = 1.0;
  c.truncate_rate = 1.0;
  c.duplicate_rate = 1.0;
  FaultInjector fi(c);
  EXPECT_EQ(fi.push(0, {}, false).size(), 2u);  // an empty datagram (duplicated) is still sent
  const std::array<std::byte, 1> one{std::byte{7}};
  const auto out = fi.push(1, one, false);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].bytes.size(), 1u);  // nothing to cut from one byte
}

TEST(FaultInjector, RejectsBadConfig) {
  FaultConfig c;
  c.reorder_rate = -0.1;
  EXPECT_THROW(FaultInjector{c}, std::invalid_argument);
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
