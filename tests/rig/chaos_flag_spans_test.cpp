// What the judge reads from the rig's /diagnostics across host clock steps: when a topic was flagged
// (FlagSpans: a status covers the period before it in the time before the step too), and a counter's
// growth in the window (counter_delta: in the order the statuses came).
#include <gtest/gtest.h>

#include "chaos_diagnostics.hpp"
#include "chaos_units.hpp"

namespace sensor_rig::rig::chaos {
namespace {

constexpr Nanos kMs = 1'000'000;
constexpr Nanos kS = 1000 * kMs;

bool covered(const Intervals& iv, Nanos t) {
  for (const auto& [b, e] : iv)
    if (t >= b && t < e) return true;
  return false;
}

TEST(FlagSpans, AFlaggedStatusCoversThePeriodBeforeItAndHalfAfter) {
  FlagSpans f;
  f.on_status("/t", 10 * kS, 100 * kS, false);
  f.on_status("/t", 11 * kS, 101 * kS, true);
  f.on_status("/t", 12 * kS, 102 * kS, false);
  const auto iv = f.intervals().at("/t");
  EXPECT_FALSE(covered(iv, 9 * kS + 400 * kMs));
  EXPECT_TRUE(covered(iv, 9 * kS + 600 * kMs));
  EXPECT_TRUE(covered(iv, 11 * kS + 400 * kMs));
  EXPECT_FALSE(covered(iv, 11 * kS + 600 * kMs));
  EXPECT_EQ(f.intervals().count("/other"), 0u);
}

// Two flagged statuses 2.5 s apart, none between (the rig's statuses came late once, ten-minute
// campaign seed 9): flagged throughout, as a diagnostics consumer shows the last status until the
// next. Not after an unflagged one, nor across more than 5 s (stale).
TEST(FlagSpans, TwoFlaggedStatusesWithNoneBetweenCoverTheTimeBetween) {
  FlagSpans f;
  f.on_status("/t", 10 * kS, 100 * kS, true);
  f.on_status("/t", 12 * kS + 500 * kMs, 102 * kS + 500 * kMs, true);
  EXPECT_TRUE(covered(f.intervals().at("/t"), 10 * kS + 800 * kMs));
  FlagSpans after_ok;
  after_ok.on_status("/t", 10 * kS, 100 * kS, false);
  after_ok.on_status("/t", 12 * kS + 500 * kMs, 102 * kS + 500 * kMs, true);
  EXPECT_FALSE(covered(after_ok.intervals().at("/t"), 10 * kS + 800 * kMs));
  FlagSpans stale;
  stale.on_status("/t", 10 * kS, 100 * kS, true);
  stale.on_status("/t", 16 * kS, 106 * kS, true);
  EXPECT_FALSE(covered(stale.intervals().at("/t"), 12 * kS));
}

// The host clock 37 s back from 5 s to 10 s (stamps of statuses during the step read -32 .. -27 s):
// the status after the step forward covers the last moments before it, in the stepped time.
TEST(FlagSpans, AStatusAfterAStepForwardCoversTheTimeBeforeTheStep) {
  FlagSpans f;
  constexpr Nanos kStep = 37 * kS;
  f.on_status("/t", 9 * kS + 100 * kMs - kStep, 109 * kS + 100 * kMs, true);  // during the step
  f.on_status("/t", 10 * kS + 100 * kMs, 110 * kS + 120 * kMs, true);         // after it (polled 20 ms late)
  const auto iv = f.intervals().at("/t");
  // Published at 9.9 s host time during the step (-27.1 s): covered, as is 9.6 s after the step.
  EXPECT_TRUE(covered(iv, 9 * kS + 900 * kMs - kStep));
  EXPECT_TRUE(covered(iv, 9 * kS + 600 * kMs));
  // Without the status after the step, 9.9 s - 37 s is not covered: the status during the step
  // covers its half period after, up to 9.6 s - 37 s.
  FlagSpans plain;
  plain.on_status("/t", 9 * kS + 100 * kMs - kStep, 0, true);
  EXPECT_FALSE(covered(plain.intervals().at("/t"), 9 * kS + 900 * kMs - kStep));
  // No step: statuses a period apart, received a period apart, add nothing beyond their own spans.
  FlagSpans steady;
  steady.on_status("/t", 1 * kS, 50 * kS, true);
  steady.on_status("/t", 2 * kS, 51 * kS + 90 * kMs, true);
  EXPECT_EQ(steady.intervals().at("/t"), (Intervals{{-500 * kMs, 2 * kS + 500 * kMs}}));
}

// A step back between two statuses: the later status (stamped in the repeated time) covers the
// time after the previous one too.
TEST(FlagSpans, AStatusAfterAStepBackCoversTheTimeAfterThePreviousStatus) {
  FlagSpans f;
  f.on_status("/t", 20 * kS, 200 * kS, false);
  f.on_status("/t", 21 * kS - 2 * kS, 201 * kS, true);  // the host stepped back 2 s in between
  const auto iv = f.intervals().at("/t");
  EXPECT_TRUE(covered(iv, 20 * kS + 800 * kMs)) << "published just before the step, flagged by the status after it";
  EXPECT_TRUE(covered(iv, 18 * kS + 500 * kMs));
}

// The fusion's scans_dropped between the window's edges, by when each status came (CLOCK_MONOTONIC),
// never by its stamp: statuses stamped while the host clock stood 37 s back came within the window.
TEST(CounterDelta, GrowthBetweenTheStatusesThatCameAtTheEdges) {
  const std::vector<std::pair<Nanos, std::uint64_t>> came{{1 * kS, 2}, {2 * kS, 3}, {3 * kS, 20}, {4 * kS, 40}, {5 * kS, 41}, {6 * kS, 41}};
  EXPECT_EQ(counter_delta(came, 2 * kS, 10 * kS), 38u) << "from 3 (at 2 s) to 41";
  EXPECT_EQ(counter_delta(came, 2 * kS + 500 * kMs, 4 * kS), 37u);
  EXPECT_EQ(counter_delta(came, 0, 10 * kS), 41u);
  EXPECT_EQ(counter_delta({}, 0, kS), 0u);
}

// The host time read twice after a clock step: what the host read again until it was stepped
// forward (a -37 s step for 5 s: 5 s, not 37; a +37 s step for 5 s, undone: the 5 s read during it).
// Before, the whole step was taken as read twice, and what was made there was left out of the
// judge's counts: the first 20 s of a campaign with a -37 s step at 20 s had "no complete sample"
// after any fault, the 32 s a +37 s step skipped the same.
TEST(DoubledVehicleTime, AStepForwardUndoneDoublesOnlyTheTimeReadDuringIt) {
  truth::Log log;
  log.faults.push_back(truth::FaultRecord{1, "host.clock_step", 5 * kS, 10 * kS, -1, "ms=37000"});
  log.faults.push_back(truth::FaultRecord{2, "host.clock_step", 100 * kS, 105 * kS, -1, "ms=-2000"});
  log.faults.push_back(truth::FaultRecord{3, "host.clock_step", 200 * kS, 201 * kS, -1, "ms=3000"});
  log.faults.push_back(truth::FaultRecord{4, "host.clock_step", 300 * kS, 305 * kS, -1, "ms=-37000"});
  const auto doubled = doubled_vehicle_time({log});
  ASSERT_EQ(doubled.size(), 4u);
  EXPECT_EQ(doubled[3].begin, 263 * kS) << "a step back of 37 s for 5 s: the 5 s read during it";
  EXPECT_EQ(doubled[3].end, 268 * kS);
  EXPECT_EQ(doubled[0].begin, 42 * kS);
  EXPECT_EQ(doubled[0].end, 47 * kS);
  EXPECT_EQ(doubled[1].begin, 98 * kS) << "a step back at its start for longer than itself: the 2 s before it are read again";
  EXPECT_EQ(doubled[1].end, 100 * kS);
  EXPECT_EQ(doubled[2].begin, 203 * kS) << "a step of 3 s for 1 s: 1 s read again";
  EXPECT_EQ(doubled[2].end, 204 * kS);
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
