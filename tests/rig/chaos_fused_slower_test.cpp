// The judge of the fused cloud (issue 26 item 8) beside a slower LIDAR (300 rpm beside 600): its
// scans span two rotations and cover both; a stopped LIDAR's do not (chaos_fused_fixture.hpp).
#include <gtest/gtest.h>

#include "chaos_check.hpp"
#include "chaos_fused_fixture.hpp"

namespace sensor_rig::rig::chaos::fused {
namespace {

// `lidar` gone from the odd rotations 10..19 (lidar.rpm_change to 300 rpm from 1 s to 2 s): the
// sweeps of those rotations without it, saying complete.
void odd_rotations_gone(Input& in, std::size_t lidar) {
  in.events.push_back(faults::FaultEvent{2, "lidar.rpm_change", kNames[lidar], 1.0, 1.0, {{"rpm", "300"}}});
  in.truths[lidar].faults.push_back(truth::FaultRecord{2, "lidar.rpm_change", kT0 + 1'000'000'000, kT0 + 2'000'000'000, 10, ""});
  for (int u = 11; u < 20; u += 2) {
    remove_scans(in, lidar, u, u + 1);
    without(in, u, lidar, false);
  }
}

// `lidar` at 300 rpm for rotations 10..19: its scans of the even ones span two rotations (twice the
// packets, at the same rate), and the sweeps they are in count them.
void slower_lidar(Input& in, std::size_t lidar) {
  odd_rotations_gone(in, lidar);
  for (auto& unit : in.truths[lidar].units)
    if (unit.unit >= 10 && unit.unit < 20) unit.parts = 2 * kParts;
  in.truths[lidar].parts.clear();
  std::uint64_t seq = 0;
  for (const auto& unit : in.truths[lidar].units)
    for (std::uint32_t q = 0; q < unit.parts; ++q) {
      const Nanos t = unit.acq_ns + q * (kPeriod / kParts);
      in.truths[lidar].parts.push_back(truth::PartRecord{seq++, unit.unit, t, 0, t, truth::Fate::kSent, 0});
    }
  for (auto& x : in.samples)
    if (x.topic == topic_of(lidar) && x.seq >= seq_of(lidar, 10) && x.seq < seq_of(lidar, 20)) x.packets = 2 * kParts;
  for (int u = 10; u < 20; u += 2) cloud_of(in, static_cast<std::uint64_t>(u)).packets += kParts;
}

// The left LIDAR at 300 rpm for rotations 10..19: each of its scans spans two rotations (twice the
// packets). The sweeps of the rotations its scans began in hold them; the others lack nothing and
// say complete without it (the fusion's rule for a slower LIDAR): held. The same sweeps saying
// complete while the left LIDAR had stopped (its scan of one rotation only) are caught.
TEST(ChaosFusedCheck, ASlowerLidarCoversTheRotationsItsScanSpansAStoppedOneDoesNot) {
  Input slow = honest(), stopped = honest();
  slower_lidar(slow, 1);
  odd_rotations_gone(stopped, 1);
  Result r = check(slow);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kFusedCloudTopic).hidden_missing, 0u);
  r = check(stopped);
  EXPECT_FALSE(r.invariants.at("fused"));
  EXPECT_TRUE(example_says(r, "sweep 11 (stamped at 1.100 s) says complete (missing 0) with 2 of 3 LIDARs; absent: left")) << result_text(r);
  EXPECT_EQ(r.topics.at(kFusedCloudTopic).hidden_missing, 5u);
}

// The matcher's boundary and the judge's may lie in different gaps where two are nearly equal: a
// slower front LIDAR's scan (two turns, begun 2 ms before the left's) in a sweep of its own, and the
// left and right scans of its rotation in the next, saying complete: the front's points of that time
// are in the cloud, in the sweep its scan began in (the matcher's `covered`): held (ten-minute
// campaign, seed 2: a 300 rpm front's turn cut short on its return to 600 rpm, "complete with 2 of
// 3"). The same sweep saying complete while the front's scan was never fused is caught.
TEST(ChaosFusedCheck, ASlowerLidarsScanInASweepOfItsOwnCoversTheSweepItSpans) {
  Input in = honest();
  slower_lidar(in, 0);
  // Rotation 12: the front's scan alone in sweep 100, the left and right in sweep 12.
  without(in, 12, 0, false);
  cloud_of(in, 12).packets = 2 * kParts;
  in.fused.sets.push_back(FusedSet{100, acq(0, 12), {member(0, 12)}});
  in.samples.push_back(cloud(100, acq(0, 12), 2 * kParts, 2 * kParts));  // partial: the left and right missing
  in.monitor[kFusedCloudTopic].received += 1;
  Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kFusedCloudTopic).hidden_missing, 0u);
  // Never fused: sweep 100 gone, its scan counted dropped; sweep 12 still says complete.
  in.fused.sets.pop_back();
  in.samples.pop_back();
  in.monitor[kFusedCloudTopic].received -= 1;
  in.fused.scans_dropped = 1;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("fused"));
  EXPECT_TRUE(example_says(r, "sweep 12 (stamped at 1.202 s) says complete (missing 0) with 2 of 3 LIDARs; absent: front")) << result_text(r);
}

}  // namespace
}  // namespace sensor_rig::rig::chaos::fused
