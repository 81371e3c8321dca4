// Synchronizer against a known truth: sets of N members at a period, each member's stamp jittered
// around the set's instant, some samples missing, arrivals delayed per member and interleaved in
// random order. The expected sets (seq per member) and incomplete counts follow from the truth.
#include "sensor_rig/timesync/synchronizer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "test_instants.hpp"

namespace sensor_rig::timesync {
namespace {
using test::kHour10;

struct Truth {
  std::vector<SyncSample> arrivals;                          // in arrival order
  std::map<std::uint64_t, std::vector<std::uint64_t>> sets;  // set index -> seq per member (complete only)
  std::uint64_t incomplete = 0;                              // sets with some but not all members
  std::uint64_t orphan_samples = 0;                          // samples of incomplete sets
};

struct Scenario {
  std::uint32_t members = 3;
  int sets = 200;
  Nanos period = 100 * kMs;
  Nanos jitter = 2 * kMs;       // |stamp - instant| <= jitter
  double missing = 0.0;         // probability a sample is missing
  Nanos max_delay = 30 * kMs;   // per sample arrival delay in [0, max_delay] (+ a per-member base)
  std::uint64_t seed = 1;
};

// Members' samples stay in order per member (as DDS delivers one writer's samples); across members
// the interleaving is random through the delays.
Truth make_truth(const Scenario& sc) {
  std::mt19937_64 rng(sc.seed);
  std::uniform_int_distribution<Nanos> jit(-sc.jitter, sc.jitter);
  std::uniform_int_distribution<Nanos> delay(0, sc.max_delay);
  std::uniform_real_distribution<double> u(0, 1);
  Truth t;
  std::vector<std::uint64_t> seq(sc.members, 0);
  std::vector<Nanos> last_arrival(sc.members, 0);
  for (int k = 0; k < sc.sets; ++k) {
    const Nanos instant = kHour10 + k * sc.period;
    std::vector<std::uint64_t> seqs;
    for (std::uint32_t m = 0; m < sc.members; ++m) {
      const std::uint64_t s = seq[m]++;
      if (u(rng) < sc.missing) continue;  // the device skipped it: the sequence has a gap
      SyncSample x{m, instant + jit(rng), s, 0};
      x.arrival_ns = std::max(last_arrival[m] + 1, x.stamp_ns + static_cast<Nanos>(m) * 3 * kMs + delay(rng));
      last_arrival[m] = x.arrival_ns;
      t.arrivals.push_back(x);
      seqs.push_back(s);
    }
    if (seqs.size() == sc.members) {
      t.sets[static_cast<std::uint64_t>(k)] = seqs;
    } else if (!seqs.empty()) {
      ++t.incomplete;
      t.orphan_samples += seqs.size();
    }
  }
  std::stable_sort(t.arrivals.begin(), t.arrivals.end(),
                   [](const SyncSample& a, const SyncSample& b) { return a.arrival_ns < b.arrival_ns; });
  return t;
}

std::vector<SyncSet> feed(Synchronizer& sync, const std::vector<SyncSample>& in) {
  std::vector<SyncSet> out;
  SyncSet s;
  Nanos now = 0;
  for (const auto& x : in) {
    now = x.arrival_ns;
    sync.poll(now);
    while (sync.pop(s)) out.push_back(s);
    EXPECT_EQ(sync.push(x, now), PushResult::kAccepted);
    while (sync.pop(s)) out.push_back(s);
  }
  sync.poll(now + 10'000 * kMs);  // the end of the stream: the last pivots time out
  while (sync.pop(s)) out.push_back(s);
  return out;
}

// Maps emitted sets back to the truth by the seq of member 0 and compares every member.
void expect_matches_truth(const std::vector<SyncSet>& got, const Truth& truth, const Scenario& sc,
                          const Synchronizer& sync) {
  std::map<std::uint64_t, std::vector<std::uint64_t>> by_first;
  for (const auto& [k, seqs] : truth.sets) by_first[seqs[0]] = seqs;
  ASSERT_EQ(got.size(), truth.sets.size());
  Nanos prev = 0;
  for (const auto& set : got) {
    ASSERT_EQ(set.samples.size(), sc.members);
    const auto it = by_first.find(set.samples[0].seq);
    ASSERT_NE(it, by_first.end()) << "set with member 0 seq " << set.samples[0].seq << " is not in the truth";
    for (std::uint32_t m = 0; m < sc.members; ++m) {
      EXPECT_EQ(set.samples[m].member, m);
      EXPECT_EQ(set.samples[m].seq, it->second[m]) << "member " << m;
    }
    EXPECT_LE(set.spread_ns, 2 * sc.jitter);
    EXPECT_GT(set.first_ns, prev) << "sets come out in time order";
    prev = set.first_ns;
  }
  EXPECT_EQ(sync.stats().sets, truth.sets.size());
  EXPECT_EQ(sync.stats().incomplete, truth.incomplete);
  EXPECT_EQ(sync.stats().dropped, truth.orphan_samples);
  EXPECT_EQ(sync.stats().late, 0u);
}

SyncConfig approx(std::uint32_t members, Nanos spread, Nanos timeout, Nanos min_interval = 0) {
  SyncConfig c;
  c.policy = SyncPolicy::kApproximate;
  c.members = members;
  c.max_spread_ns = spread;
  c.timeout_ns = timeout;
  if (min_interval > 0) c.min_interval_ns.assign(members, min_interval);
  return c;
}

TEST(Synchronizer, ApproximateShuffledArrivalsMatchTheTruth) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    Scenario sc;
    sc.seed = seed;
    sc.members = 2 + static_cast<std::uint32_t>(seed % 9);  // 2..10 members
    const Truth t = make_truth(sc);
    Synchronizer sync(approx(sc.members, 5 * kMs, 1000 * kMs));
    const auto got = feed(sync, t.arrivals);
    SCOPED_TRACE("seed " + std::to_string(seed));
    expect_matches_truth(got, t, sc, sync);
  }
}

TEST(Synchronizer, ApproximateWithMissingSamplesCountsIncompleteSets) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    Scenario sc;
    sc.seed = seed;
    sc.members = 3 + static_cast<std::uint32_t>(seed % 5);
    sc.missing = 0.08;
    const Truth t = make_truth(sc);
    ASSERT_GT(t.incomplete, 10u);  // the scenario does exercise it
    Synchronizer sync(approx(sc.members, 5 * kMs, 1000 * kMs));
    const auto got = feed(sync, t.arrivals);
    SCOPED_TRACE("seed " + std::to_string(seed));
    expect_matches_truth(got, t, sc, sync);
  }
}

TEST(Synchronizer, DelaysBeyondAPeriodAndAMinIntervalStillMatch) {
  // One member arrives up to 250 ms (2.5 periods) late; the inter-message bound is 50 ms.
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    Scenario sc;
    sc.seed = seed;
    sc.members = 4;
    sc.missing = 0.05;
    sc.max_delay = 250 * kMs;
    const Truth t = make_truth(sc);
    Synchronizer sync(approx(sc.members, 5 * kMs, 2000 * kMs, 50 * kMs));
    const auto got = feed(sync, t.arrivals);
    SCOPED_TRACE("seed " + std::to_string(seed));
    expect_matches_truth(got, t, sc, sync);
  }
}

TEST(Synchronizer, AFastMemberGivesItsNearestSampleEvenWhenItArrivesLast) {
  // A 10 Hz camera and a 333 Hz IMU-like member (3 ms period, 40 ms later on the wire): the set
  // is the fast sample nearest each camera stamp, which is only known once the one after it is in.
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<Nanos> phase(0, 3 * kMs - 1), delay(0, 2 * kMs);
    std::vector<SyncSample> in;
    std::vector<std::uint64_t> truth;
    const Nanos p0 = kHour10 + phase(rng);
    for (std::uint64_t i = 0; i < 700; ++i) {
      const Nanos t = p0 + static_cast<Nanos>(i) * 3 * kMs;
      in.push_back({1, t, i, t + 40 * kMs + delay(rng)});
    }
    for (std::uint64_t k = 0; k < 20; ++k) {
      const Nanos t = kHour10 + 10 * kMs + static_cast<Nanos>(k) * 100 * kMs + phase(rng);
      in.push_back({0, t, k, t + delay(rng)});
      // Nearest fast sample (ties: the earlier one, as the synchronizer's smaller before-gap)
      const Nanos rel = t - p0;
      const std::uint64_t below = static_cast<std::uint64_t>(rel / (3 * kMs));
      const Nanos gap_below = rel - static_cast<Nanos>(below) * 3 * kMs;
      truth.push_back(gap_below <= 3 * kMs - gap_below ? below : below + 1);
    }
    std::stable_sort(in.begin(), in.end(), [](const SyncSample& a, const SyncSample& b) { return a.arrival_ns < b.arrival_ns; });
    Synchronizer sync(approx(2, 5 * kMs, 1000 * kMs));
    const auto got = feed(sync, in);
    ASSERT_EQ(got.size(), truth.size()) << "seed " << seed;
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].samples[0].seq, k);
      EXPECT_EQ(got[k].samples[1].seq, truth[k]) << "seed " << seed << " set " << k;
      EXPECT_LE(got[k].spread_ns, 1'500'000);
    }
  }
}

TEST(Synchronizer, ExactPolicyNeedsIdenticalStamps) {
  Scenario sc;
  sc.jitter = 0;
  sc.missing = 0.1;
  sc.members = 5;
  const Truth t = make_truth(sc);
  SyncConfig c;
  c.policy = SyncPolicy::kExact;
  c.members = sc.members;
  c.timeout_ns = 1000 * kMs;
  Synchronizer sync(c);
  const auto got = feed(sync, t.arrivals);
  expect_matches_truth(got, t, sc, sync);
  for (const auto& s : got) EXPECT_EQ(s.spread_ns, 0);
}

TEST(Synchronizer, ExactPolicyEmitsAsSoonAsTheLastMemberArrives) {
  SyncConfig c;
  c.policy = SyncPolicy::kExact;
  c.members = 2;
  Synchronizer sync(c);
  EXPECT_EQ(sync.push({0, kHour10, 7, kHour10}, kHour10), PushResult::kAccepted);
  EXPECT_EQ(sync.ready(), 0u);
  EXPECT_EQ(sync.push({1, kHour10, 9, kHour10}, kHour10), PushResult::kAccepted);
  SyncSet s;
  ASSERT_TRUE(sync.pop(s));
  EXPECT_EQ(s.samples[0].seq, 7u);
  EXPECT_EQ(s.samples[1].seq, 9u);
  EXPECT_EQ(s.spread_ns, 0);
}

TEST(Synchronizer, PicksTheSmallestSpreadAndDropsTheSkippedSample) {
  // A: 0, 10 ms; B: 9 ms -> {A@10, B@9} (spread 1 ms); A@0 is in no set.
  Synchronizer sync(approx(2, 20 * kMs, 1000 * kMs));
  sync.push({0, kHour10, 0, kHour10}, kHour10);
  sync.push({0, kHour10 + 10 * kMs, 1, kHour10}, kHour10);
  sync.push({1, kHour10 + 9 * kMs, 0, kHour10}, kHour10);
  SyncSet s;
  ASSERT_TRUE(sync.pop(s));
  EXPECT_EQ(s.samples[0].seq, 1u);
  EXPECT_EQ(s.samples[1].seq, 0u);
  EXPECT_EQ(s.spread_ns, 1 * kMs);
  EXPECT_EQ(sync.stats().dropped, 1u);
  EXPECT_EQ(sync.stats().dropped_per_member[0], 1u);
}

TEST(Synchronizer, WithoutABoundASetWaitsForALaterSampleWithOneItIsFinalAtOnce) {
  // Stereo pair 0.2 ms apart.
  Synchronizer wait(approx(2, 5 * kMs, 1000 * kMs));
  wait.push({0, kHour10, 0, kHour10}, kHour10);
  wait.push({1, kHour10 + 200'000, 0, kHour10}, kHour10);
  EXPECT_EQ(wait.ready(), 0u) << "member 0 may still send a sample nearer the pivot";
  wait.push({0, kHour10 + 100 * kMs, 1, kHour10 + 100 * kMs}, kHour10 + 100 * kMs);
  EXPECT_EQ(wait.ready(), 1u);

  Synchronizer bounded(approx(2, 5 * kMs, 1000 * kMs, 50 * kMs));
  bounded.push({0, kHour10, 0, kHour10}, kHour10);
  bounded.push({1, kHour10 + 200'000, 0, kHour10}, kHour10);
  EXPECT_EQ(bounded.ready(), 1u);
}

TEST(Synchronizer, TimeoutDecidesWithWhatIsThereAndADeadMemberGivesIncompleteSets) {
  Synchronizer sync(approx(3, 5 * kMs, 200 * kMs));
  // Member 2 is dead. Ten sets' worth of members 0 and 1.
  for (int k = 0; k < 10; ++k) {
    const Nanos t = kHour10 + k * 100 * kMs;
    sync.push({0, t, static_cast<std::uint64_t>(k), t}, t);
    sync.push({1, t + kMs, static_cast<std::uint64_t>(k), t}, t);
    sync.poll(t + 50 * kMs);
  }
  sync.poll(kHour10 + 5000 * kMs);
  EXPECT_EQ(sync.stats().sets, 0u);
  EXPECT_EQ(sync.stats().incomplete, 10u);
  EXPECT_EQ(sync.stats().dropped, 20u);
  EXPECT_GT(sync.stats().timeouts, 0u);
  // Before the timeout nothing is decided.
  Synchronizer young(approx(3, 5 * kMs, 200 * kMs));
  young.push({0, kHour10, 0, kHour10}, kHour10);
  young.poll(kHour10 + 199 * kMs);
  EXPECT_EQ(young.stats().dropped, 0u);
  young.poll(kHour10 + 200 * kMs);
  EXPECT_EQ(young.stats().dropped, 1u);
}

TEST(Synchronizer, TimeoutEmitsTheBestCompleteSetItHas) {
  Synchronizer sync(approx(2, 5 * kMs, 200 * kMs));
  sync.push({0, kHour10, 0, kHour10}, kHour10);
  sync.push({1, kHour10 + kMs, 0, kHour10}, kHour10);
  EXPECT_EQ(sync.ready(), 0u);  // member 0 might still send a nearer one
  sync.poll(kHour10 + 250 * kMs);
  EXPECT_EQ(sync.ready(), 1u);
  EXPECT_EQ(sync.stats().timeouts, 1u);
}

TEST(Synchronizer, LateDuplicateAndBadInputsAreRefusedAndCounted) {
  Synchronizer sync(approx(2, 5 * kMs, 1000 * kMs, 50 * kMs));
  sync.push({0, kHour10, 0, kHour10}, kHour10);
  EXPECT_EQ(sync.push({0, kHour10, 0, kHour10}, kHour10), PushResult::kDuplicate);
  sync.push({1, kHour10 + kMs, 0, kHour10}, kHour10);
  ASSERT_EQ(sync.ready(), 1u);
  // Member 1's sample of the same instant comes again, and an older one: late.
  EXPECT_EQ(sync.push({1, kHour10 + kMs, 0, kHour10}, kHour10), PushResult::kLate);
  EXPECT_EQ(sync.push({1, kHour10 - 100 * kMs, 0, kHour10}, kHour10), PushResult::kLate);
  EXPECT_EQ(sync.push({5, kHour10, 0, kHour10}, kHour10), PushResult::kBadMember);
  EXPECT_EQ(sync.stats().late, 2u);
  EXPECT_EQ(sync.stats().duplicates, 1u);
  EXPECT_EQ(sync.stats().pushed, 2u);
}

TEST(Synchronizer, SpreadBeyondTheLimitMakesNoSet) {
  Synchronizer sync(approx(2, 5 * kMs, 1000 * kMs, 50 * kMs));
  sync.push({0, kHour10, 0, kHour10}, kHour10);
  sync.push({1, kHour10 + 6 * kMs, 0, kHour10}, kHour10);
  sync.push({0, kHour10 + 100 * kMs, 1, kHour10}, kHour10);
  sync.push({1, kHour10 + 104 * kMs, 1, kHour10}, kHour10);
  SyncSet s;
  ASSERT_TRUE(sync.pop(s));
  EXPECT_EQ(s.samples[0].seq, 1u);
  EXPECT_EQ(s.spread_ns, 4 * kMs);
  EXPECT_FALSE(sync.pop(s));
  EXPECT_EQ(sync.stats().dropped, 2u);
  EXPECT_EQ(sync.stats().incomplete, 2u) << "6 ms apart, beyond the 5 ms spread: two sets' samples";
}

TEST(Synchronizer, QueueOverflowDropsTheOldest) {
  SyncConfig c = approx(2, 5 * kMs, 100'000 * kMs);
  c.max_queue = 4;
  Synchronizer sync(c);
  for (int k = 0; k < 10; ++k) sync.push({0, kHour10 + k * 100 * kMs, static_cast<std::uint64_t>(k), kHour10}, kHour10);
  EXPECT_EQ(sync.stats().overflows, 6u);
  EXPECT_EQ(sync.stats().dropped, 6u);
}

// Two members at 10 Hz (the rig's sets: min interval 50 ms, timeout 500 ms); member 1's stamp at
// `wild` is `offset` away from its instant, or from there on when `sustained`.
struct StepRun {
  std::uint64_t sets = 0;
  SyncStats stats;
};
StepRun run_with_step(int wild, Nanos offset, bool sustained, bool both) {
  Synchronizer sync(approx(2, 5 * kMs, 500 * kMs, 50 * kMs));
  SyncSet set;
  StepRun r;
  for (int k = 0; k < 50; ++k) {
    const Nanos t = kHour10 + k * 100 * kMs;
    const bool stepped = sustained ? k >= wild : k == wild;
    const auto seq = static_cast<std::uint64_t>(k);
    sync.push({0, t + (stepped && both ? offset : 0), seq, t + 5 * kMs}, t + 5 * kMs);
    sync.push({1, t + kMs + (stepped ? offset : 0), seq, t + 8 * kMs}, t + 8 * kMs);
    sync.poll(t + 60 * kMs);
    while (sync.pop(set)) ++r.sets;
  }
  r.stats = sync.stats();
  return r;
}

// Issue 27 item 6: one stamp 10 s in the future (a camera clock glitch, a frame reordered by its
// device clock) was queued; once member 1's normal samples were used it was the pivot, timed out,
// and its drop pinned member 1 (every later sample "late") for 10 s: 15 sets of 49. Now it is
// held, member 1's next sample shows it wild: counted, in no set, and every other set is made.
TEST(Synchronizer, OneFutureStampIsCountedAndDoesNotStallItsMember) {
  const auto r = run_with_step(10, 10'000 * kMs, false, false);
  EXPECT_EQ(r.sets, 49u);
  EXPECT_EQ(r.stats.implausible, 1u);
  EXPECT_EQ(r.stats.late, 0u);
  EXPECT_EQ(r.stats.jumps, 0u);
  EXPECT_EQ(r.stats.dropped_per_member[1], 1u);  // the wild one
}

// A step that lasts (the host clock stepped forward, every member's mapping follows): each member's
// first stamp there waits for its next, then both go in; no set is lost.
TEST(Synchronizer, ASustainedStepIsFollowed) {
  const auto r = run_with_step(20, 5'000 * kMs, true, true);
  EXPECT_EQ(r.sets, 50u);
  EXPECT_EQ(r.stats.jumps, 2u);
  EXPECT_EQ(r.stats.implausible, 0u);
  EXPECT_EQ(r.stats.late, 0u);
}

TEST(Synchronizer, RejectsBadConfig) {
  SyncConfig c;
  c.members = 0;
  EXPECT_THROW(Synchronizer{c}, std::invalid_argument);
  c.members = 2;
  c.min_interval_ns = {1};
  EXPECT_THROW(Synchronizer{c}, std::invalid_argument);
}

}  // namespace
}  // namespace sensor_rig::timesync
