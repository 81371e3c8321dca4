// clock_pair_now() (common/clock.hpp): vehicle time and CLOCK_MONOTONIC at one instant. Ground
// truth: scripted clocks whose offset is known exactly, with a preemption put between two reads;
// two bare reads are off by the preemption (the fake V4L2 camera's truth 1.26 ms off, ten-minute
// campaign seed 4), the bracketed pair by at most half of the bracket it keeps.
#include <gtest/gtest.h>

#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig {
namespace {

constexpr Nanos kOffset = 1'796'000'000 * kSec;  // vehicle = monotonic + this, exactly

// A monotonic clock that advances 50 ns a read, and `pauses[i]` more before the i-th read of the
// vehicle clock returns (the thread preempted between its reads).
struct ScriptedClocks {
  std::vector<Nanos> pauses;
  Nanos mono = 1'000 * kSec;
  int vehicle_reads = 0, mono_reads = 0;
  Nanos read_monotonic() {
    ++mono_reads;
    return mono += 50;
  }
  Nanos read_vehicle() {
    const auto i = static_cast<std::size_t>(vehicle_reads++);
    mono += 50 + (i < pauses.size() ? pauses[i] : 0);  // the preemption ends before the read
    return mono + kOffset;
  }
  ClockPair pair() {
    return tightest_clock_pair([this] { return read_monotonic(); }, [this] { return read_vehicle(); });
  }
};

TEST(ClockPair, WithoutPreemptionOneTryIsExact) {
  ScriptedClocks c;
  const auto p = c.pair();
  EXPECT_EQ(c.vehicle_reads, 1);
  EXPECT_EQ(c.mono_reads, 2);
  EXPECT_EQ(p.vehicle_minus_monotonic(), kOffset);
}

TEST(ClockPair, APreemptionBetweenTheReadsIsNotTakenForTheOffset) {
  ScriptedClocks bare;
  bare.pauses = {1'260 * kUs};
  const Nanos mono = bare.read_monotonic(), vehicle = bare.read_vehicle();  // what the mocks did
  EXPECT_EQ(vehicle - mono - kOffset, 1'260 * kUs + 50) << "two bare reads carry the preemption";

  ScriptedClocks c;
  c.pauses = {1'260 * kUs};  // the first try preempted, the second not
  const auto p = c.pair();
  EXPECT_EQ(c.vehicle_reads, 2);
  EXPECT_LE(std::abs(p.vehicle_minus_monotonic() - kOffset), 50) << p.vehicle_minus_monotonic() - kOffset;
}

TEST(ClockPair, EveryTryPreemptedKeepsTheTightestAndStops) {
  ScriptedClocks c;
  c.pauses = {3 * kMs, 400 * kUs, 2 * kMs, 900 * kUs, 0};
  const auto p = c.pair();
  EXPECT_EQ(c.vehicle_reads, 4) << "four tries at most";
  // The 400 us bracket: its midpoint is off the vehicle read by at most half of it.
  EXPECT_LE(std::abs(p.vehicle_minus_monotonic() - kOffset), 200 * kUs + 50);
  EXPECT_GE(std::abs(p.vehicle_minus_monotonic() - kOffset), 100 * kUs) << "not a later, wider try";
}

TEST(ClockPair, TheRealClocksAgreeWithEachOtherToTheirBracket) {
  const auto a = clock_pair_now();
  const auto b = clock_pair_now();
  EXPECT_GE(b.monotonic_ns, a.monotonic_ns);
  EXPECT_LE(std::abs(b.vehicle_minus_monotonic() - a.vehicle_minus_monotonic()), 100 * kUs);
}

}  // namespace
}  // namespace sensor_rig
