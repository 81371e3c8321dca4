// The sweep matcher against ground truth (sweep_matcher_sim.hpp) while LIDARs move or turn at other
// rpm: back from a slower rpm or a stall on a phase of their own, a boundary moved by half a turn,
// a LIDAR above or below the rig's rpm (its scans short of a turn, or spanning two), stamps late by
// half a rotation, phases jittering across two equal gaps.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "sweep_matcher_sim.hpp"

namespace sensor_rig::drivers::sim {
namespace {

// A LIDAR back from 300 to 600 rpm on another phase: its last slow turn cut short (165 ms, the mock's
// rotor keeps turning as a motor would), its next scans 35 ms earlier in the rotation. Its arrivals
// moved with its stamps, so no clock stepped: its phase is taken at once. Before, held as a possible
// clock step for 3 scans, each was fused with the rotation before its own (the whole-rig campaign,
// seed 25, front LIDAR at 19.08 s). And the cut slow turn reaches into the rotation its successor
// begins in: that sweep waits for the successor; before, it went out complete without it, its scan
// then dropped as late (seed 25 again, 19.05 s).
TEST(SweepMatcher, ALidarBackFromASlowerRpmOnAPhaseOfItsOwnIsTakenAtOnce) {
  std::vector<TrueScan> scans;
  for (std::int64_t n = 0; n < 40; ++n)
    for (std::uint32_t s = 1; s < 3; ++s) {
      const Nanos stamp = n * kPeriod + (s == 1 ? 0 : 2 * kMs);
      scans.push_back({s, n, stamp, stamp + kDelivery});
    }
  for (std::int64_t j = 0; j < 6; ++j) {  // 300 rpm at 66 ms: nearest the others' next rotation
    const Nanos stamp = 2 * j * kPeriod + 66 * kMs;
    const Nanos span = j < 5 ? 2 * kPeriod : 165 * kMs;  // the last turn cut short
    scans.push_back({0, 2 * j + 1, stamp, stamp + span + 2 * kMs, span, 2});
  }
  for (std::int64_t n = 12; n < 40; ++n) {  // 600 rpm again, at 31 ms: with the others' same rotation
    const Nanos stamp = n * kPeriod + 31 * kMs;
    scans.push_back({0, n, stamp, stamp + kDelivery, kPeriod});
  }
  SimulatedRig run(3);
  run.feed(scans);
  for (const auto& e : run.emitted_) {
    if (e.scans[0].rotation < 11) continue;
    for (const auto& t : e.scans)
      EXPECT_EQ(t.rotation, e.scans[0].rotation) << "sweep emitted at " << e.at / kMs << " ms mixes rotations";
  }
  for (std::int64_t n = 13; n < 40; ++n) {
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  }
  // Rotation 12 holds the first fast scan, which began in it, though the cut slow turn reached into
  // it: its sweep waited for that scan rather than going out complete without it (it came late then).
  for (const auto& d : run.dropped_) EXPECT_LT(d.rotation, 10) << "dropped: the scan of rotation " << d.rotation;  // the start's first may be
  const Emitted* twelve = run.sweep_of(12);
  ASSERT_NE(twelve, nullptr);
  EXPECT_TRUE(std::any_of(twelve->scans.begin(), twelve->scans.end(), [](const TrueScan& t) { return t.source == 0; }));
  EXPECT_TRUE(twelve->complete);
}

// Ten-minute campaign, seed 4 (lidar.rpm_change of the front to 300 rpm, 225.8-227.8 s): the left
// LIDAR at 0 ms into the rotation, the right at 58.6, the front at 32.1 (300 rpm), back at 600 rpm on
// the left's phase. The widest gap moves from 58.6-100 to 0-58.6: the boundary from 79.3 to 29.3 ms,
// half a turn, the short way round decided by microseconds of the right's phase (it drifted 14 us
// in between). Moved across the front's new phase, the front's first scans were numbered a
// rotation lower and fused with the left's and right's scans of the turn before (two sweeps 100 ms
// wide). A sweep's scans lie within the rig's spread (58.6 ms here), whichever way it rounds.
// (The campaign's own scans: SweepMatcherReplay.ALidarBackFromSlowerOnAnothersPhaseIs...)
TEST(SweepMatcher, ABoundaryMovedByHalfATurnKeepsTheMovedLidarsScanWithItsOwnTurn) {
  constexpr Nanos left = 0, right = 58'600'000;
  for (const Nanos back : {Nanos{-10'000}, Nanos{10'000}}) {  // the front's return, just before or after the left
    for (const Nanos drift : {Nanos{-20'000}, Nanos{20'000}}) {  // the right's phase, before the return against after
      SCOPED_TRACE("front back " + std::to_string(back) + " ns off the left, the right drifted " + std::to_string(drift) + " ns");
      std::vector<TrueScan> scans;
      for (std::int64_t n = 0; n < 50; ++n) {
        const Nanos r = right + (n < 19 ? drift : 0);
        scans.push_back({1, n, n * kPeriod + left, n * kPeriod + left + kDelivery, kPeriod - kMs});
        scans.push_back({2, n, n * kPeriod + r, n * kPeriod + r + kDelivery, kPeriod - kMs});
      }
      const Nanos front = 32'100'000;
      for (std::int64_t n = 0; n < 10; ++n) scans.push_back({0, n, n * kPeriod + front, n * kPeriod + front + kDelivery, kPeriod - kMs});
      for (std::int64_t n = 10; n < 20; n += 2) {  // 300 rpm; the last turn cut by the return
        const Nanos stamp = n * kPeriod + front;
        const Nanos span = n < 18 ? 2 * kPeriod - kMs : 20 * kPeriod + back - stamp - kMs;
        scans.push_back({0, n, stamp, stamp + span + 2 * kMs, span, 2});
      }
      for (std::int64_t n = 20; n < 50; ++n) {  // 600 rpm again, on the left's turn (10 us off it)
        const Nanos stamp = n * kPeriod + left + back;
        scans.push_back({0, n, stamp, stamp + kDelivery, kPeriod - kMs});
      }
      SimulatedRig run(3);
      run.feed(scans);
      for (const auto& e : run.emitted_) {
        Nanos lo = e.scans[0].stamp, hi = lo;
        for (const auto& t : e.scans) lo = std::min(lo, t.stamp), hi = std::max(hi, t.stamp);
        EXPECT_LT(hi - lo, 60 * kMs) << "sweep emitted at " << e.at / kMs << " ms spans " << (hi - lo) / kMs << " ms";
      }
      EXPECT_LE(run.dropped_.size(), 2u);
    }
  }
}

// A LIDAR at 1200 rpm beside two at 600 for ten rotations (lidar.rpm_change, rpm=1200): two 50 ms
// scans per rotation, its phase moving by half a turn every scan. Each scan joins the rotation its
// stamp lies in by the rig's phases; of two in one rotation the second is repeated (dropped and
// counted); no sweep mixes rotations, each holds one of its scans, and it is whole again after.
// (A regression test: the LIDAR campaign's seed 3 mixed 20 sweeps in such a window on the matcher
// before d4995c1; this simulation of it holds on that matcher too, so the cause was elsewhere.)
TEST(SweepMatcher, ALidarAboveTheRigsRpmJoinsTheRotationsItsScansLieIn) {
  // The campaign's rig (the three phases within a millisecond, the fast scans 3 and 53 ms into the
  // rotation: the second 2.5 ms past the boundary) and one with the phases spread.
  struct Rig {
    std::vector<Nanos> phases;
    Nanos fast_first;
  };
  // And a rig whose LIDARs came back on phases of their own (0 and 47 ms): the fast scans' phases,
  // 20 and 70 ms, counted in the widest gap, moved the boundary across the 47 ms LIDAR's phase each
  // scan (73.5 with one, 23.5 with the other), renumbering its rotations (the ten-minute campaign,
  // seed 1: 373 sweeps mixed rotations while the right LIDAR ran at 1200 rpm).
  for (const Rig& rig : {Rig{{900'000, 900'000, 0}, 3 * kMs}, Rig{kPhases, 45 * kMs}, Rig{{0, 47 * kMs, 10 * kMs}, 20 * kMs}}) {
    SCOPED_TRACE("fast scans at " + std::to_string(rig.fast_first / kMs) + " ms");
    auto scans = rig_scans(rig.phases, 0, 40);
    erase_scans(scans, 2, 10, 20);
    for (auto& t : scans)
      if (t.span == 0) t.span = kPeriod - kMs;
    // The boundary lies in the middle of the widest gap between the phases at the rig's rpm.
    Nanos lo = *std::max_element(rig.phases.begin(), rig.phases.end());
    Nanos hi = *std::min_element(rig.phases.begin(), rig.phases.end()) + kPeriod;
    const Nanos boundary = (lo + hi) / 2;
    for (std::int64_t n = 10; n < 20; ++n)
      for (const Nanos at : {rig.fast_first, rig.fast_first + 50 * kMs}) {
        const Nanos stamp = n * kPeriod + at;
        scans.push_back({2, at < boundary ? n : n + 1, stamp, stamp + 50 * kMs + 2 * kMs, 50 * kMs - kMs});
      }
    std::stable_sort(scans.begin(), scans.end(), [](const TrueScan& a, const TrueScan& b) { return a.stamp < b.stamp; });
    SimulatedRig run(3);
    run.feed(scans);
    for (const auto& e : run.emitted_)
      for (const auto& t : e.scans)
        EXPECT_EQ(t.rotation, e.scans[0].rotation) << "sweep emitted at " << e.at / kMs << " ms mixes rotations";
    for (std::int64_t n = 0; n < 40; ++n) {
      const Emitted* e = run.sweep_of(n);
      ASSERT_NE(e, nullptr) << n;
      EXPECT_TRUE(e->complete) << "rotation " << n;
    }
    // Rotations 11..20 each had two of its scans (the last its first scan back at 600 rpm, behind
    // the fast one that began in it): the second of each dropped as repeated.
    for (const auto& d : run.dropped_) EXPECT_EQ(d.source, 2u) << "dropped: source " << d.source << " rotation " << d.rotation;
    EXPECT_EQ(run.dropped_.size(), 10u);
    EXPECT_EQ(run.m_.counters().repeated_scans + run.m_.counters().late_scans, 10u);  // the last after its sweep went out
  }
}

// Two PTP LIDARs whose stamps run half a rotation late for a while (the rig's mapped stamps after a
// host.network_delay or a clock step's slew; their data and arrivals keep the rig's rotation), then
// snap back, beside a GPS-timed one that stays true. A step of P/2 reads +P/2 or -P/2 by a few
// microseconds: the rig chaos campaigns (whole rig seed 1; LIDARs seed 3) fused the Pandar's (or
// the Ouster's) rotation N with the others' N+1 and called the sweep complete, its scan of N
// dropped as late. Every sweep must hold one rotation, whole, with nothing dropped.
TEST(SweepMatcher, StampsHalfARotationLateAndBackKeepTheirRotation) {
  const std::vector<Nanos> phases{0, 0, -900'000};  // the campaign's VLP-32C, OS-LEGACY, Pandar40P
  for (const Nanos late : {50 * kMs - 45'000, 50 * kMs, 50 * kMs + 45'000}) {
    SCOPED_TRACE("stamps late by " + std::to_string(late) + " ns");
    auto scans = rig_scans(phases, 0, 40);
    for (auto& t : scans) {
      t.span = kPeriod - kMs;
      if (t.source != 0 && t.rotation >= 10 && t.rotation < 25) t.stamp += late;
    }
    SimulatedRig run(3);
    run.feed(scans);
    run.expect_truth(scans.size());
    EXPECT_TRUE(run.dropped_.empty());
    for (std::int64_t n = 0; n < 40; ++n) {
      ASSERT_NE(run.sweep_of(n), nullptr) << n;
      EXPECT_TRUE(run.sweep_of(n)->complete) << n;
    }
  }
}

// Phases that split the rotation into nearly equal gaps and jitter by 1-2 ms: any of the three
// groupings is one rotation of the rig, but it must stay the same one (a boundary that moved back
// and forth would split and mix sweeps).
TEST(SweepMatcher, JitterAcrossEqualGapsKeepsTheBoundary) {
  const std::vector<Nanos> phases{0, 33 * kMs, 66 * kMs};
  auto scans = rig_scans(phases, 0, 60);
  for (auto& t : scans) t.stamp += (t.rotation % 2 == 0 ? 1 : -1) * static_cast<Nanos>(t.source) * kMs;
  SimulatedRig run(3);
  run.feed(scans);
  EXPECT_TRUE(run.dropped_.empty());
  std::set<std::vector<std::int64_t>> groupings;  // per sweep: each source's rotation - the first source's
  std::size_t complete = 0;
  for (const auto& e : run.emitted_) {
    if (!e.complete) continue;
    ++complete;
    std::vector<std::int64_t> g(3);
    for (const auto& t : e.scans) g[t.source] = t.rotation;
    for (auto& r : g) r -= e.scans[0].rotation;
    groupings.insert(g);
  }
  EXPECT_GE(complete, 58u);  // the first and the last rotation may be cut by the grouping
  EXPECT_EQ(groupings.size(), 1u);
  EXPECT_EQ(run.m_.counters().partial_timeout + run.m_.counters().partial_next_sweep, run.emitted_.size() - complete);
}

// Mixed rpm: LIDAR 1 turns at 300 rpm beside two at 600 (issue 26): its scan spans two rotations
// of the period, is stamped at its first firing and handed over two periods later. `from`: the
// rotation it slows down at (600 rpm before); `phase`: where its slow scans begin.
std::vector<TrueScan> mixed_rpm_scans(std::int64_t from, std::int64_t last, Nanos phase) {
  auto scans = rig_scans(kPhases, 0, last);
  erase_scans(scans, 1, from, last);
  for (std::int64_t n = from; n + 2 <= last; n += 2) {
    const Nanos stamp = n * kPeriod + phase;
    scans.push_back({1, n, stamp, stamp + 2 * kPeriod + 2 * kMs, 2 * kPeriod - kMs, 2});
  }
  for (auto& t : scans)
    if (t.rotations == 1 && t.span == 0) t.span = kPeriod - kMs;  // the node tells every scan's span
  return scans;
}

// Before: the 300 rpm LIDAR never made the fused cloud (every other sweep waited for it in vain and
// declared it dead; its next scan came after its sweep was written: dropped as late). Now each of
// its scans joins the sweep of the rotation it began in, which waits for it; the sweep of the
// rotation its scan also spans lacks nothing and goes out without waiting.
TEST(SweepMatcher, SlowerLidarJoinsTheRotationItsScanBeganIn) {
  for (const Nanos phase : {20 * kMs, 37 * kMs}) {
    SCOPED_TRACE("phase " + std::to_string(phase / kMs) + " ms");
    const auto scans = mixed_rpm_scans(10, 40, phase);
    SimulatedRig run(3);
    run.feed(scans);
    run.expect_truth(scans.size());
    EXPECT_TRUE(run.dropped_.empty()) << run.dropped_.size() << " scans dropped, first of LIDAR " << run.dropped_[0].source;
    std::size_t slow_fused = 0;
    for (std::int64_t n = 0; n < 40; ++n) {
      const Emitted* e = run.sweep_of(n);
      ASSERT_NE(e, nullptr) << n;
      EXPECT_TRUE(e->complete) << "rotation " << n;
      EXPECT_EQ(run.wait_of(n), 0) << "rotation " << n << " waited past its last scan";
      for (const auto& t : e->scans) slow_fused += t.source == 1 && t.rotations == 2 ? 1 : 0;
    }
    EXPECT_EQ(slow_fused, 15u) << "every 300 rpm scan in a sweep";
    EXPECT_EQ(run.m_.counters().missing, (std::vector<std::uint64_t>{0, 0, 0}));
    EXPECT_EQ(run.m_.counters().covered, 15u);
  }
}

// A slow scan short of its turn (its last packets lost: it spans 1.3 periods) is still a slow
// scan while the LIDAR's stamps step by two periods; a slow LIDAR that stops costs one wait
// (timeout + one period), then no sweep waits for it, and its sweeps say what they lack.
TEST(SweepMatcher, SlowerLidarShortScanAndStop) {
  auto scans = mixed_rpm_scans(0, 40, 20 * kMs);
  for (auto& t : scans)
    if (t.source == 1 && t.rotation == 10) t.span = 130 * kMs;
  erase_scans(scans, 1, 30, 40);
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  EXPECT_TRUE(run.dropped_.empty());
  for (std::int64_t n = 0; n < 30; ++n) EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  // Rotation 30 waited for its slow scan until the timeout and one period more, then no longer.
  EXPECT_EQ(run.sweep_of(30)->at, 30 * kPeriod + kDelivery + kTimeout + kPeriod);
  EXPECT_FALSE(run.sweep_of(30)->complete);
  // Rotations 31 and 32, whole but for it by then, go out at that moment; no later one waits.
  EXPECT_EQ(run.sweep_of(31)->at, run.sweep_of(30)->at);
  EXPECT_EQ(run.sweep_of(32)->at, run.sweep_of(30)->at);
  for (std::int64_t n = 31; n < 40; ++n) EXPECT_FALSE(run.sweep_of(n)->complete) << n;
  for (std::int64_t n = 33; n < 40; ++n) {
    EXPECT_EQ(run.wait_of(n), 0) << n;
    EXPECT_FALSE(run.sweep_of(n)->complete) << n;
  }
}

// The first scan of a LIDAR slowing to 300 rpm is handed over two periods after its stamp: on a
// phase late in the rotation (60 ms after the first LIDAR's) it comes after its sweep timed out
// (the matcher knew it at 600 rpm then) and is dropped as late. The next rotation's sweep, which
// that scan spans, is still open (the third LIDAR's scans come 40 ms later than the others'): it
// must not wait for the slow LIDAR (nothing more of that time will come), and must not say
// complete, for the cloud has none of that LIDAR's points of that time. Before, it said complete
// ("covered") by the scan it had dropped: the whole-rig campaign's fused judge, "complete with 2 of
// 3". From the second slow scan on, every sweep is whole.
TEST(SweepMatcher, ASlowScanDroppedAsLateCoversNothingInTheCloud) {
  const std::vector<Nanos> phases{0, 60 * kMs, 30 * kMs};
  auto scans = rig_scans(phases, 0, 40);
  erase_scans(scans, 1, 10, 40);
  for (std::int64_t n = 10; n + 2 <= 40; n += 2) {
    const Nanos stamp = n * kPeriod + phases[1];
    scans.push_back({1, n, stamp, stamp + 2 * kPeriod + 2 * kMs, 2 * kPeriod - kMs, 2});
  }
  for (auto& t : scans) {
    if (t.rotations == 1 && t.span == 0) t.span = kPeriod - kMs;
    if (t.source == 2) t.arrival += 40 * kMs;
  }
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  ASSERT_EQ(run.dropped_.size(), 1u);
  EXPECT_EQ(run.dropped_[0].source, 1u);
  EXPECT_EQ(run.dropped_[0].rotation, 10);
  ASSERT_NE(run.sweep_of(11), nullptr);
  EXPECT_FALSE(run.sweep_of(10)->complete);
  EXPECT_FALSE(run.sweep_of(11)->complete) << "said complete by the scan it dropped";
  EXPECT_EQ(run.wait_of(11), 0) << "waited for a scan that cannot come";
  for (std::int64_t n = 12; n < 38; ++n) EXPECT_TRUE(run.sweep_of(n)->complete) << n;
}

}  // namespace
}  // namespace sensor_rig::drivers::sim
