// The judge's reconciliation of the rig's own loss count (rig/src/chaos_count.hpp): by number, with
// the count's window edges and vehicle time read twice allowed for, and nothing else.
#include <gtest/gtest.h>

#include "chaos_count.hpp"

namespace sensor_rig::rig::chaos {
namespace {

CountFacts facts(std::uint64_t rig_counted, std::uint64_t not_published) {
  CountFacts f;
  f.rig_counted = rig_counted;
  f.not_published = not_published;
  return f;
}

TEST(ChaosCount, AnExactCountLeavesNothingUnaccounted) {
  const auto v = reconcile_count(facts(10, 10));
  EXPECT_FALSE(v.over_counted);
  EXPECT_EQ(v.unaccounted_all, 0U);
  EXPECT_EQ(v.counted_lost, 10U);
}

TEST(ChaosCount, LossesTheRigDidNotCountAreUnaccounted) {
  const auto v = reconcile_count(facts(7, 10));
  EXPECT_EQ(v.unaccounted_all, 3U);
  EXPECT_EQ(v.unaccounted, 3U);
  EXPECT_EQ(v.counted_lost, 7U);
}

TEST(ChaosCount, LossesNearTheEdgesMayBeInTheCountOrNotOnlyThose) {
  auto f = facts(8, 10);
  f.edge_in = 2;  // two of the ten lie within count_edge_ns inside the window's edges
  EXPECT_EQ(reconcile_count(f).unaccounted_all, 0U);
  f.rig_counted = 7;  // a third one missing from the count is not the edges'
  EXPECT_EQ(reconcile_count(f).unaccounted_all, 1U);
  f = facts(12, 10);
  f.edge_out = 2;  // two just outside the window may be in the count
  EXPECT_FALSE(reconcile_count(f).over_counted);
  f.rig_counted = 13;
  const auto v = reconcile_count(f);
  EXPECT_TRUE(v.over_counted);
  EXPECT_EQ(v.most, 12U);
  EXPECT_EQ(v.unaccounted_all, 0U);  // an over-count is phantom loss, not also a shortfall
}

// A V4L2 frame done and gone with its device at a disconnect before the rig dequeued it: no call
// tells of it, so the count may have it or not (whole-rig campaign seed 25: 7 not published, 6
// counted, one of them such a frame: "neither published nor counted"). Only those.
TEST(ChaosCount, LossesNoCallTellsOfMayBeInTheCountOrNot) {
  auto f = facts(6, 7);
  EXPECT_EQ(reconcile_count(f).unaccounted_all, 1U);
  f.unseeable = 1;
  EXPECT_EQ(reconcile_count(f).unaccounted_all, 0U);
  f.rig_counted = 7;  // counted from the device's rate: no phantom either
  EXPECT_FALSE(reconcile_count(f).over_counted);
  f.rig_counted = 5;  // one more missing from the count is not the unplug's
  EXPECT_EQ(reconcile_count(f).unaccounted_all, 1U);
  f.rig_counted = 8;
  EXPECT_TRUE(reconcile_count(f).over_counted);
}

TEST(ChaosCount, UnitsOfTimeReadTwiceAreHeldByNumberAndNotChargedToJudgedUnits) {
  auto f = facts(3, 0);
  f.doubled_made = 5;
  f.doubled_samples = 2;  // three units of the doubled second were not published: the count may cover them
  auto v = reconcile_count(f);
  EXPECT_EQ(v.doubled_lost, 3U);
  EXPECT_FALSE(v.over_counted);
  EXPECT_EQ(v.unaccounted_all, 0U);
  f.rig_counted = 2;
  v = reconcile_count(f);
  EXPECT_EQ(v.unaccounted_all, 1U);
  EXPECT_EQ(v.unaccounted, 0U);  // no judged unit is missing: sent = published + counted + unaccounted holds
  f.rig_counted = 4;
  EXPECT_TRUE(reconcile_count(f).over_counted);
}

// A LIDAR without numbering counts the whole turns of a silence unheard (stream_gap.hpp): lost or
// never made. They cover the units lost whole in a silence, no others (a loss elsewhere stays
// unaccounted), and beyond those and the turns the device made nothing in they are phantom.
TEST(ChaosCount, UnheardTurnsCoverUnitsLostWholeInASilenceOnly) {
  auto f = facts(2, 4);  // a 3.07-turn burst: the scans at its ends counted lost, 2 whole turns inside
  EXPECT_EQ(reconcile_count(f).unaccounted, 2U) << "before: the rig said nothing of the 2 turns";
  f.rig_unheard = 2;
  f.unheard_units = 2;
  auto v = reconcile_count(f);
  EXPECT_EQ(v.unaccounted, 0U);
  EXPECT_EQ(v.counted_lost, 2U);
  EXPECT_EQ(v.counted_unheard, 2U);
  EXPECT_FALSE(v.over_unheard);
  // A killed mock's silence elsewhere: 20 turns unheard, none made. They do not cover a loss the
  // rig hid beside them.
  f.rig_unheard = 22;
  f.turns_unmade = 20;
  f.not_published = 5;
  v = reconcile_count(f);
  EXPECT_FALSE(v.over_unheard);
  EXPECT_EQ(v.unaccounted, 1U);
  // More unheard than lost whole and unmade: phantom.
  f.rig_unheard = 23;
  EXPECT_TRUE(reconcile_count(f).over_unheard);
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
