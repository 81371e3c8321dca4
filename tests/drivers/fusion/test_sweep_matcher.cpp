// The sweep matcher against ground truth: a simulated rig of phase-locked LIDARs makes scans whose
// rotation is known (rotation n of LIDAR s is stamped n * period + phase_s), hands them over in
// arrival order as the node does (each LIDAR's scans in order), and polls at every deadline. Every
// emitted sweep must hold scans of one rotation only and say complete exactly when it has all; a
// stopped LIDAR must cost one timeout, then no sweep waits for it; a late scan joins its own
// rotation or is dropped, never another's; a LIDAR that comes back is fused from its next rotation;
// a clock step (the stamps jump, arrival time does not) costs at most the rotations it cuts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <tuple>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

namespace sensor_rig::drivers {
namespace {
constexpr Nanos kPeriod = 100 * kMs;
constexpr Nanos kTimeout = 150 * kMs;
constexpr Nanos kDelivery = kPeriod + 2 * kMs;  // a scan is handed over one rotation + 2 ms after its first firing

struct TrueScan {
  std::uint32_t source = 0;
  std::int64_t rotation = 0;  // the truth
  Nanos stamp = 0;            // what the LIDAR stamped (vehicle time: steps with the clock)
  Nanos arrival = 0;          // handed to the node (monotonic)
  Nanos span = 0;             // its last point's time after its stamp (0: not told, one period)
  std::int64_t rotations = 1;  // the truth: rotations of the rig's period it spans (2: 300 rpm beside 600)
};

struct Emitted {
  Nanos at = 0;
  bool complete = false;
  std::vector<TrueScan> scans;
};

// Scans of `rotations` [first, last) for LIDARs at `phases`, delivered kDelivery after their stamp.
std::vector<TrueScan> rig_scans(const std::vector<Nanos>& phases, std::int64_t first, std::int64_t last) {
  std::vector<TrueScan> v;
  for (std::int64_t n = first; n < last; ++n)
    for (std::uint32_t s = 0; s < phases.size(); ++s) {
      const Nanos stamp = n * kPeriod + phases[s];
      v.push_back({s, n, stamp, stamp + kDelivery});
    }
  return v;
}

void erase_scans(std::vector<TrueScan>& v, std::uint32_t source, std::int64_t from, std::int64_t to) {
  std::erase_if(v, [&](const TrueScan& t) { return t.source == source && t.rotation >= from && t.rotation < to; });
}

TrueScan& find_scan(std::vector<TrueScan>& v, std::uint32_t source, std::int64_t rotation) {
  for (auto& t : v)
    if (t.source == source && t.rotation == rotation) return t;
  throw std::logic_error("no such scan");
}

// The node's loop on simulated time: scans in arrival order (each source's in order), ready()
// after each and at every deadline in between.
class SimulatedRig {
 public:
  explicit SimulatedRig(std::uint32_t sources) : m_({sources, kPeriod, kTimeout}), sources_(sources) {}

  void feed(std::vector<TrueScan> scans) {
    std::map<std::uint32_t, Nanos> last;  // a source's scans arrive in order
    for (auto& t : scans) {
      t.arrival = std::max(t.arrival, last[t.source]);
      last[t.source] = t.arrival;
    }
    std::stable_sort(scans.begin(), scans.end(), [](const TrueScan& a, const TrueScan& b) { return a.arrival < b.arrival; });
    fed_.insert(fed_.end(), scans.begin(), scans.end());
    for (const auto& t : scans) {
      advance(t.arrival);
      const auto place = m_.push(t.source, t.stamp, t.arrival, t.span);
      if (place.late)
        dropped_.push_back(t);
      else
        open_[place.sweep].push_back(t);
      drain(t.arrival);
    }
    if (!scans.empty()) advance(scans.back().arrival + 10 * kTimeout);
  }

  // Every emitted sweep holds one rotation, says complete exactly when it has every source, and
  // every scan fed is emitted or dropped.
  void expect_truth(std::size_t fed) const {
    std::size_t seen = dropped_.size();
    for (const auto& e : emitted_) {
      ASSERT_FALSE(e.scans.empty());
      std::set<std::uint32_t> sources;
      for (const auto& t : e.scans) {
        EXPECT_EQ(t.rotation, e.scans[0].rotation) << "sweep emitted at " << e.at / kMs << " ms mixes rotations "
                                                  << e.scans[0].rotation << " and " << t.rotation;
        sources.insert(t.source);
      }
      EXPECT_EQ(sources.size(), e.scans.size());
      // Complete exactly when every source is in, or its scan that began in an earlier rotation
      // spans this one (a slower LIDAR: nothing of that time is missing).
      std::size_t covered = 0;
      for (std::uint32_t src = 0; src < sources_; ++src)
        if (!sources.contains(src) && spanned_by_earlier(src, e.scans[0].rotation)) ++covered;
      EXPECT_EQ(e.complete, sources.size() + covered == sources_) << "rotation " << e.scans[0].rotation;
      seen += e.scans.size();
    }
    EXPECT_EQ(seen, fed);
    EXPECT_TRUE(open_.empty());
  }

  // The emitted sweep holding rotation n's scans (the first, when split), or nullptr.
  [[nodiscard]] const Emitted* sweep_of(std::int64_t n) const {
    for (const auto& e : emitted_)
      if (e.scans[0].rotation == n) return &e;
    return nullptr;
  }
  // How long after its last scan arrived a rotation's sweep went out.
  [[nodiscard]] Nanos wait_of(std::int64_t n) const {
    const Emitted* e = sweep_of(n);
    if (e == nullptr) return -1;
    Nanos last = 0;
    for (const auto& t : e->scans) last = std::max(last, t.arrival);
    return e->at - last;
  }

  // A scan of `source` that began before rotation n spans it, and is in the cloud (a scan dropped
  // as late covers nothing).
  [[nodiscard]] bool spanned_by_earlier(std::uint32_t source, std::int64_t n) const {
    const auto dropped = [&](const TrueScan& t) {
      return std::any_of(dropped_.begin(), dropped_.end(), [&](const TrueScan& d) { return d.source == t.source && d.stamp == t.stamp; });
    };
    return std::any_of(fed_.begin(), fed_.end(), [&](const TrueScan& t) {
      return t.source == source && t.rotation < n && n < t.rotation + t.rotations && !dropped(t);
    });
  }

  SweepMatcher m_;
  std::uint32_t sources_;
  std::vector<TrueScan> fed_;
  std::map<std::uint64_t, std::vector<TrueScan>> open_;
  std::vector<Emitted> emitted_;
  std::vector<TrueScan> dropped_;

 private:
  void drain(Nanos now) {
    while (auto c = m_.ready(now)) {
      auto it = open_.find(c->id);
      ASSERT_NE(it, open_.end()) << "sweep " << c->id << " was never given a scan";
      std::size_t present = 0;
      for (bool p : c->present) present += p ? 1 : 0;
      EXPECT_EQ(present, it->second.size());
      emitted_.push_back({now, c->complete, std::move(it->second)});
      open_.erase(it);
    }
  }
  void advance(Nanos to) {
    for (Nanos d = m_.deadline(); d >= 0 && d <= to; d = m_.deadline()) drain(d);
  }
};

const std::vector<Nanos> kPhases{0, 20 * kMs, 45 * kMs};  // the widest gap: 45 -> 100 ms

// Emitted sweeps holding scans of more than one true rotation.
std::size_t mixed_sweeps(const SimulatedRig& run) {
  return static_cast<std::size_t>(std::count_if(run.emitted_.begin(), run.emitted_.end(), [](const Emitted& e) {
    return std::any_of(e.scans.begin(), e.scans.end(), [&](const TrueScan& t) { return t.rotation != e.scans[0].rotation; });
  }));
}

TEST(SweepMatcher, CompleteSweepsGoOutWhenTheLastScanArrives) {
  auto scans = rig_scans(kPhases, 0, 30);
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  ASSERT_EQ(run.emitted_.size(), 30u);
  for (std::int64_t n = 0; n < 30; ++n) EXPECT_EQ(run.wait_of(n), 0) << n;
  EXPECT_EQ(run.m_.counters().complete, 30u);
}

// The rig's phases at any offset from the vehicle clock's period grid (the node sees them at
// whatever instant the car started). The boundary moved into the widest gap as the third LIDAR's
// first scan came; when that move crossed the grid's zero it was stored wrapped, which renumbered
// every rotation by one: 9 offsets of 40 split the first sweep, the third scan alone in the next
// (test_fusion_dds failed 1 run in 4 on this).
TEST(SweepMatcher, AnyOffsetOfThePhasesFromTheGridGroupsTheSameRotations) {
  for (Nanos offset = 0; offset < kPeriod; offset += kPeriod / 40) {
    SCOPED_TRACE("phases offset by " + std::to_string(offset / 1000) + " us");
    std::vector<Nanos> phases;
    for (const Nanos p : kPhases) phases.push_back(p + offset);
    auto scans = rig_scans(phases, 0, 10);
    SimulatedRig run(3);
    run.feed(scans);
    run.expect_truth(scans.size());
    EXPECT_EQ(run.emitted_.size(), 10u);
    EXPECT_EQ(run.m_.counters().complete, 10u);
  }
}

// Whichever LIDAR delivers first: the rotation decides, so a rig whose first scan is a late phase
// is grouped the same (the spread rule grouped {45, 100, 120} when 45 came first).
TEST(SweepMatcher, StartupOnALatePhaseKeepsRotationsApart) {
  auto scans = rig_scans(kPhases, 0, 10);
  erase_scans(scans, 0, 0, 1);
  erase_scans(scans, 1, 0, 1);
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  for (std::int64_t n = 1; n < 10; ++n) {
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  }
}

TEST(SweepMatcher, StoppedLidarCostsOneTimeoutThenNoSweepWaitsForIt) {
  auto scans = rig_scans(kPhases, 0, 40);
  erase_scans(scans, 1, 10, 40);  // the middle phase stops after rotation 9
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  ASSERT_EQ(run.emitted_.size(), 40u);
  // Rotation 10 waited for it (the timeout after its first scan arrived), then it is dead: rotation
  // 11, whole by then, goes out at the same moment, and no later one waits.
  EXPECT_EQ(run.sweep_of(10)->at, 10 * kPeriod + kDelivery + kTimeout);
  EXPECT_EQ(run.sweep_of(11)->at, run.sweep_of(10)->at);
  for (std::int64_t n = 12; n < 40; ++n) EXPECT_EQ(run.wait_of(n), 0) << "rotation " << n << " waited";
  EXPECT_EQ(run.m_.counters().missing, (std::vector<std::uint64_t>{0, 30, 0}));
  EXPECT_EQ(run.m_.counters().partial_timeout, 1u);
  EXPECT_TRUE(run.dropped_.empty());
}

// The latest phase stops: the next scan of the first phase does not close its rotation early,
// nor does it have to wait for it (the spread rule closed each sweep one rotation later).
TEST(SweepMatcher, StoppedLatestPhaseDoesNotDelayTheOthers) {
  auto scans = rig_scans(kPhases, 0, 40);
  erase_scans(scans, 2, 5, 40);
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  EXPECT_EQ(run.sweep_of(5)->at, 5 * kPeriod + kDelivery + kTimeout);  // waited for it once
  EXPECT_EQ(run.sweep_of(6)->at, run.sweep_of(5)->at);
  for (std::int64_t n = 7; n < 40; ++n) EXPECT_EQ(run.wait_of(n), 0) << "rotation " << n << " waited";
}

// The last phase's scan of rotation 5 comes after the first phase's scan of rotation 6 (within
// the timeout): it completes rotation 5; the spread rule fused it into rotation 6 as "complete".
TEST(SweepMatcher, LateScanJoinsItsOwnRotation) {
  auto scans = rig_scans(kPhases, 0, 12);
  find_scan(scans, 2, 5).arrival = 6 * kPeriod + kDelivery + 3 * kMs;
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  ASSERT_EQ(run.emitted_.size(), 12u);
  for (const auto& e : run.emitted_) EXPECT_TRUE(e.complete);
  EXPECT_TRUE(run.dropped_.empty());
}

// Later than the timeout: rotation 5 goes out without it, and rotation 6, whole but for the same
// LIDAR (its next scan queued behind), with it; both scans are dropped, never fused into rotation 6.
TEST(SweepMatcher, ScanLaterThanTheTimeoutIsDroppedNotFusedIntoTheNextRotation) {
  auto scans = rig_scans(kPhases, 0, 12);
  find_scan(scans, 2, 5).arrival = 5 * kPeriod + kDelivery + kTimeout + 10 * kMs;
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  ASSERT_EQ(run.dropped_.size(), 2u);
  EXPECT_EQ(run.dropped_[0].rotation, 5);
  EXPECT_EQ(run.dropped_[1].rotation, 6);
  EXPECT_FALSE(run.sweep_of(5)->complete);
  for (std::int64_t n = 7; n < 12; ++n) EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  EXPECT_EQ(run.m_.counters().late_scans, 2u);
}

// A LIDAR that skipped one rotation (its decoder discarded the scan): its next scan shows the
// rotation is done for it, so the rotation goes out then, before the timeout.
TEST(SweepMatcher, SkippedRotationClosesWhenTheLidarMovesOn) {
  auto scans = rig_scans(kPhases, 0, 12);
  erase_scans(scans, 0, 5, 6);
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  EXPECT_EQ(run.sweep_of(5)->at, 6 * kPeriod + kDelivery);  // with its scan of rotation 6
  for (std::int64_t n = 6; n < 12; ++n) EXPECT_TRUE(run.sweep_of(n)->complete) << n;
}

TEST(SweepMatcher, LidarThatComesBackIsFusedFromItsNextRotation) {
  for (std::uint32_t gone = 0; gone < 3; ++gone) {
    SCOPED_TRACE("lidar " + std::to_string(gone));
    auto scans = rig_scans(kPhases, 0, 40);
    erase_scans(scans, gone, 10, 20);
    SimulatedRig run(3);
    run.feed(scans);
    run.expect_truth(scans.size());
    for (std::int64_t n = 21; n < 40; ++n) {
      ASSERT_NE(run.sweep_of(n), nullptr) << n;
      EXPECT_TRUE(run.sweep_of(n)->complete) << n;
      EXPECT_EQ(run.wait_of(n), 0) << n;
    }
    EXPECT_LE(run.dropped_.size(), 1u);  // at most its first scan back, when the others had gone out
  }
}

// The vehicle clock steps (the LIDARs' stamps with it, one scan after another; arrival time is
// monotonic): at most the rotations the step cuts are partial, no sweep mixes rotations, and the
// rig is whole again two rotations later.
void expect_recovers_from_step(Nanos step, Nanos at) {
  SCOPED_TRACE("step " + std::to_string(step / kMs) + " ms");
  auto scans = rig_scans(kPhases, 0, 40);
  for (auto& t : scans)
    if (t.stamp > at) t.stamp += step;
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  const std::int64_t cut = at / kPeriod;
  for (std::int64_t n = 0; n < 40; ++n) {
    if (n >= cut && n <= cut + 1) continue;
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
    EXPECT_EQ(run.wait_of(n), 0) << n;
  }
  EXPECT_TRUE(run.dropped_.empty());
}

TEST(SweepMatcher, ClockStepForward) { expect_recovers_from_step(1000 * 1000 * kMs + 37 * kMs, 10 * kPeriod + 10 * kMs); }

TEST(SweepMatcher, ClockStepBack) {
  expect_recovers_from_step(-537 * kMs, 10 * kPeriod + 10 * kMs);  // within the rotations it remembers
  expect_recovers_from_step(-3 * 1000 * kMs - 37 * kMs, 10 * kPeriod + 30 * kMs);
}

// A free-running LIDAR restarted with another phase (no clock step: the others keep theirs): the
// boundary is placed anew and the rig is whole again within a few rotations, never mixed.
TEST(SweepMatcher, OwnPhaseChangeOfOneLidar) {
  auto scans = rig_scans(kPhases, 0, 40);
  for (auto& t : scans)
    if (t.source == 0 && t.rotation >= 10) {
      t.stamp += 30 * kMs;  // phase 0 -> 30 ms: a jump, by itself (the others keep theirs)
      t.arrival += 30 * kMs;
    }
  SimulatedRig run(3);
  run.feed(scans);
  run.expect_truth(scans.size());
  EXPECT_GE(run.m_.counters().phase_steps, 1u);
  for (std::int64_t n = 0; n < 40; ++n) {
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  }
}

// A LIDAR stalled for three rotations comes back on another phase of its own (the whole-rig campaign,
// seed 25: the front's mock SIGSTOPped 300 ms, its phase 35 ms later after it): the others show no
// step, so its new phase is taken once each of them has handed over a scan begun after its return.
// Before, the matcher held its old phase for 3 of its scans, each fused with the rotation before
// its own (the rig's phase moved from 31 to 66 ms past the others': its scans now lie 34 ms before
// their next rotation, 66 ms after this one).
TEST(SweepMatcher, AStalledLidarBackOnAPhaseOfItsOwnIsTakenOnceTheOthersShowNoStep) {
  auto scans = rig_scans({31 * kMs, 0, 2 * kMs}, 0, 40);
  erase_scans(scans, 0, 10, 13);
  for (auto& t : scans)
    if (t.source == 0 && t.rotation >= 13) {
      t.stamp += 35 * kMs;
      t.arrival += 35 * kMs;
      t.rotation += 1;  // the truth: nearest the others' next rotation
    }
  SimulatedRig run(3);
  run.feed(scans);
  EXPECT_LE(mixed_sweeps(run), 1u) << "only the returned scan itself may be placed by the old phase";
  EXPECT_GE(run.m_.counters().phase_steps, 1u);
  for (std::int64_t n = 17; n < 40; ++n) {
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  }
}

// A LIDAR back from a restart on a phase of its own (front: 20 ms before the left's, then 16 ms
// after it; right 27 ms after the left), its first scan handed over 20 ms late: the arrivals do not
// show the move, so it is held as a possible clock step. The left's next scan, begun after the
// front's return and unmoved, refutes that at once; the right's comes 12 ms late, after the front's
// second scan. Waiting for both witnesses fused that second scan with the next rotation too (the
// LIDAR-fault campaign seed 3 at 157.2 s, replayed through the matcher: 2 sweeps mixed); one
// witness proves it, and only the returned scan itself may be placed by the old phase.
TEST(SweepMatcher, OneUnmovedWitnessRefutesAStepAtOnce) {
  auto scans = rig_scans({-20 * kMs, 15 * kMs, 42 * kMs}, 0, 40);
  erase_scans(scans, 0, 10, 40);
  for (std::int64_t n = 13; n < 40; ++n) {
    const Nanos stamp = n * kPeriod + 31 * kMs;
    scans.push_back({0, n, stamp, stamp + kDelivery + (n == 13 ? 20 * kMs : 0)});
  }
  for (auto& t : scans)
    if (t.source == 2) t.arrival += 12 * kMs;
  SimulatedRig run(3);
  run.feed(scans);
  EXPECT_LE(mixed_sweeps(run), 1u) << "only the returned scan itself may be placed by the old phase";
  for (std::int64_t n = 15; n < 40; ++n) {
    ASSERT_NE(run.sweep_of(n), nullptr) << n;
    EXPECT_TRUE(run.sweep_of(n)->complete) << n;
  }
}

// A LIDAR whose encoder stuck for five turns: its first scan after lost its head, 24 of 100 ms
// stamped 75 ms into its turn (the decoder stamps the first intact firing), its end where its turns
// end. By that stamp it lies past the boundary (72.5 ms), in the next rotation; it is the tail of
// its own: placed there, or dropped as late, never fused with the next rotation, and the next scan
// is not a second one of that rotation (ten-minute campaign, seed 2: the left LIDAR after a
// lidar.stuck_azimuth, 16 of 64 packets, fused with the others' next rotation).
TEST(SweepMatcher, AScanThatLostItsHeadIsPlacedAsTheTurnItIsTheTailOf) {
  // 76 ms of the turn lost; and 92 (its last 8 ms left, stamped 8 ms before the next turn: within
  // an eighth of a turn of the phase, it was taken for that turn's; ten-minute campaign, seed 4).
  // And the scan before the freeze cut short at 92 ms (published with what it had): its span is no
  // turn to count back by (taken for one, the 92 ms case's end lay 8 ms off the phase, as far as its
  // stamp, and the scan went with the next turn).
  for (const auto& [lost, left, cut] : {std::tuple{75 * kMs, 24 * kMs, Nanos{0}}, std::tuple{92 * kMs, 7 * kMs, Nanos{0}},
                                        std::tuple{Nanos{92'200'000}, Nanos{7'800'000}, Nanos{92'200'000}}}) {
    SCOPED_TRACE(std::to_string(lost / kMs) + " ms of the turn lost, the scan before cut at " + std::to_string(cut / kMs) + " ms");
    auto scans = rig_scans(kPhases, 0, 40);
    for (auto& t : scans) t.span = kPeriod - kMs;  // the node tells every scan's span
    erase_scans(scans, 0, 10, 15);
    if (cut > 0) find_scan(scans, 0, 9).span = cut;
    TrueScan& tail = find_scan(scans, 0, 15);
    tail.stamp += lost;
    tail.span = left;
    SimulatedRig run(3);
    run.feed(scans);
    run.expect_truth(scans.size());
    EXPECT_EQ(mixed_sweeps(run), 0u);
    EXPECT_EQ(run.m_.counters().head_lost_scans, 1u);
    EXPECT_EQ(run.m_.counters().repeated_scans, 0u);
    ASSERT_NE(run.sweep_of(16), nullptr);
    EXPECT_TRUE(run.sweep_of(16)->complete);
  }
  // Its tail on its phase instead (the turn's last packets lost): placed by its stamp, as before.
  auto cut = rig_scans(kPhases, 0, 40);
  find_scan(cut, 0, 15).span = 24 * kMs;
  SimulatedRig run2(3);
  run2.feed(cut);
  run2.expect_truth(cut.size());
  EXPECT_EQ(run2.m_.counters().head_lost_scans, 0u);
  EXPECT_EQ(mixed_sweeps(run2), 0u);
}

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

TEST(SweepMatcher, UnknownSourceIsDroppedAndConfigChecked) {
  SweepMatcher m({2, kPeriod, kTimeout});
  EXPECT_TRUE(m.push(7, 0, kDelivery).late);
  EXPECT_EQ(m.counters().late_scans, 1u);
  EXPECT_THROW(SweepMatcher({0, 1, 1}), std::invalid_argument);
  EXPECT_THROW(SweepMatcher({1, 0, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace sensor_rig::drivers
