// The sweep matcher on scans of a real campaign (campaign_replays.hpp), as the fusion node met them:
// every sweep it emits holds scans of one true rotation. Both stretches were mixed by the matcher of
// stop 44 (replayed: one sweep each) and are what its rules for a scan that lost its head and for a
// LIDAR back from the dead are for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "campaign_replays.hpp"
#include "sensor_rig/common/floor_div.hpp"
#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr Nanos kReplayPeriod = 100 * kMs;

struct Replayed {
  std::vector<std::vector<replay::Scan>> sweeps;  // as emitted
  std::vector<replay::Scan> dropped;
  SweepCounters counters;
};

bool flagged(const replay::Scan&) { return false; }
bool flagged(const replay::FlaggedScan& s) { return s.unsynchronized; }
replay::Scan plain(const replay::Scan& s) { return s; }
replay::Scan plain(const replay::FlaggedScan& s) { return {s.source, s.stamp, s.arrival, s.span, s.truth}; }

// The node's loop: each scan pushed at its arrival, ready() after it and at every deadline between.
template <class ScanT>
Replayed run(const std::vector<ScanT>& scans) {
  SweepMatcher m({3, kReplayPeriod, 150 * kMs});
  Replayed out;
  std::map<std::uint64_t, std::vector<replay::Scan>> open;
  const auto drain = [&](Nanos now) {
    while (auto c = m.ready(now)) {
      out.sweeps.push_back(std::move(open[c->id]));
      open.erase(c->id);
    }
  };
  for (const auto& f : scans) {
    const replay::Scan s = plain(f);
    for (Nanos d = m.deadline(); d >= 0 && d <= s.arrival; d = m.deadline()) drain(d);
    const auto place = m.push(s.source, s.stamp, s.arrival, s.span, flagged(f));
    if (place.late)
      out.dropped.push_back(s);
    else
      open[place.sweep].push_back(s);
    drain(s.arrival);
  }
  for (Nanos d = m.deadline(); d >= 0; d = m.deadline()) drain(d);
  out.counters = m.counters();
  return out;
}

// The true rotation of a scan: periods from the boundary in the middle of the widest gap between
// the LIDARs' true phases (the fused judge's rule).
std::int64_t rotation(Nanos truth, Nanos boundary) { return floor_div(truth - boundary, kReplayPeriod); }

std::string describe(const std::vector<replay::Scan>& sweep) {
  std::string s;
  for (const auto& m : sweep) s += " src " + std::to_string(m.source) + " true " + std::to_string(m.truth / kMs) + " ms;";
  return s;
}

// The left LIDAR's first scan after its encoder stuck (16 of 64 packets, stamped 75 ms into its
// turn) is the tail of its turn: placed as that turn (there, its sweep gone, dropped and counted),
// never fused with the front and right LIDARs' next rotation. True phases: front 0, left 20.5,
// right 98.9 ms: the boundary at 59.7 ms.
TEST(SweepMatcherReplay, AScanAfterAStuckEncoderIsNotFusedWithTheNextRotation) {
  const Replayed r = run(replay::kStuckLeft);
  constexpr Nanos kBoundary = 59'700'000;
  for (const auto& sweep : r.sweeps)
    for (const auto& m : sweep) EXPECT_EQ(rotation(m.truth, kBoundary), rotation(sweep.front().truth, kBoundary)) << describe(sweep);
  EXPECT_EQ(r.counters.head_lost_scans, 1u);
  EXPECT_LE(r.dropped.size(), 2u);
}

// A LIDAR moved at `back` (true time): a sweep wholly before it holds one rotation of the boundary
// `before`, one wholly after it one of `after`; sweeps with scans from both sides are the move's
// regrouping and not judged. Sweeps with a scan before `from` (the matcher's start) are skipped.
// Returns how many were judged.
std::size_t judge_around_a_move(const Replayed& r, Nanos back, Nanos before, Nanos after, Nanos from = 0) {
  std::size_t judged = 0;
  for (const auto& sweep : r.sweeps) {
    if (std::any_of(sweep.begin(), sweep.end(), [&](const replay::Scan& m) { return m.truth < from; })) continue;
    const bool later = sweep.front().truth >= back;
    if (std::any_of(sweep.begin(), sweep.end(), [&](const replay::Scan& m) { return (m.truth >= back) != later; })) continue;
    const Nanos boundary = later ? after : before;
    for (const auto& m : sweep) EXPECT_EQ(rotation(m.truth, boundary), rotation(sweep.front().truth, boundary)) << describe(sweep);
    ++judged;
  }
  return judged;
}

// The front LIDAR back from a kill 61 ms later in its turn, its first scan 50 ms late: its phase is
// its own (it was dead), so its scans join the rotation of their true acquisition. True phases
// before: right 26.5, front 39.4, left 73.0 ms (the boundary at 99.75 ms); after: front 0 (49.75 ms).
TEST(SweepMatcherReplay, ALidarBackFromAKillIsNotFusedWithAnotherRotation) {
  const Replayed r = run(replay::kFrontKilled);
  EXPECT_GE(judge_around_a_move(r, 1'900'000'000, 99'750'000, 49'750'000), r.sweeps.size() - 2);
  EXPECT_LE(r.dropped.size(), 3u);
}

// The front LIDAR back from 300 rpm on the left's phase (0 ms; the right at 58.6): the widest gap
// moves from 58.6-100 to 0-58.6 and the boundary from 79.3 to 29.3 ms, half a turn. The matcher fused
// the front's first two scans with the left's and right's scans of the turn before (seed 4: two
// sweeps "mix rotations", 100 ms wide). Every sweep's scans lie within the rig's spread, and in one
// rotation of the boundary of their time (judged from 200 ms: before, the front's slow phase was
// not yet seen).
TEST(SweepMatcherReplay, ALidarBackFromSlowerOnAnothersPhaseIsNotFusedWithTheTurnBefore) {
  const Replayed r = run(replay::kFrontBackFromSlowOnTheLeftsPhase);
  constexpr Nanos kFrom = 200'000'000;
  for (const auto& sweep : r.sweeps) {
    Nanos lo = sweep.front().truth, hi = lo;
    for (const auto& m : sweep) lo = std::min(lo, m.truth), hi = std::max(hi, m.truth);
    if (lo >= kFrom) {
      EXPECT_LT(hi - lo, 60 * kMs) << describe(sweep);
    }
  }
  EXPECT_GE(judge_around_a_move(r, 1'150'000'000, 79'300'000, 29'300'000, kFrom), r.sweeps.size() - 4);
  EXPECT_LE(r.dropped.size(), 2u);
}

// The left and right LIDARs' flagged stamps, 85 ms late under a network hold, step back to their
// truth (true phases: right 22.7, left 34.5, front 99.3 ms: the boundary at 66.9 ms). From then on,
// their scans join the front's scan 24 ms before them, the rotation of their true acquisition. Held
// as a possible clock step for three scans (a flagged LIDAR's stamps move with its own mapping, not
// the vehicle clock), the matcher fused them with the front's next scan, 64 ms after them (seed 9,
// ten minutes: 3 sweeps "mix rotations"). The sweeps before, grouped by the late stamps, are the
// rig's flagged warning and not judged here.
TEST(SweepMatcherReplay, FlaggedStampsSteppingBackToTheirTruthKeepTheirRotation) {
  const Replayed r = run(replay::kFlaggedBackToTruth);
  constexpr Nanos kBack = 1'250'000'000, kBoundary = 66'900'000;
  EXPECT_GE(judge_around_a_move(r, kBack, kBoundary, kBoundary, kBack), 6u);
  EXPECT_LE(r.dropped.size(), 3u);
}

}  // namespace
}  // namespace sensor_rig::drivers
