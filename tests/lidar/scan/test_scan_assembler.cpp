// ScanAssembler: buffer recycling (the hot path allocates nothing), sequence numbers, partial
// scans, drops carried over, flush, the reserve guess and the lookahead scan Hesai uses.
#include <gtest/gtest.h>

#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "sensor_rig/lidar/scan_assembler.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"

namespace sensor_rig::lidar {
namespace {

// One packet with `points` points into the current scan, stamped `stamp`.
void add_packet(ScanAssembler& a, std::size_t points, Nanos stamp = 1000) {
  ASSERT_TRUE(a.accept(PacketStatus::kOk));
  a.begin_packet();
  a.current().touch(stamp, stamp + 5);
  for (std::size_t i = 0; i < points; ++i)
    a.scan().points.push_back(PointXYZIRT{1.0F, 2.0F, 3.0F, 4.0F, static_cast<std::uint32_t>(i), 0, 0, 0});
}

TEST(ScanAssembler, RecycledBufferIsReusedForALaterScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 64}, stats);
  add_packet(a, 10);
  auto s0 = a.end_scan(true);
  ASSERT_TRUE(s0);
  const PointXYZIRT* p0 = s0->points.data();
  ASSERT_NE(p0, nullptr);
  a.recycle(std::move(s0->points));
  EXPECT_EQ(a.spare_count(), 1U);

  // The scan already in progress has its own buffer; the one after it gets the recycled one.
  add_packet(a, 10);
  auto s1 = a.end_scan(true);
  ASSERT_TRUE(s1);
  EXPECT_NE(s1->points.data(), p0);
  EXPECT_EQ(a.spare_count(), 0U);
  EXPECT_EQ(a.scan().points.data(), p0);  // same allocation, cleared
  EXPECT_TRUE(a.scan().points.empty());
  add_packet(a, 3);
  auto s2 = a.end_scan(true);
  ASSERT_TRUE(s2);
  EXPECT_EQ(s2->points.data(), p0);
  EXPECT_EQ(s2->points.size(), 3U);
}

TEST(ScanAssembler, KeepsAtMostSpareBuffersAndNoEmptyOnes) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8, .spare_buffers = 2}, stats);
  a.recycle(std::vector<PointXYZIRT>{});  // no capacity: nothing to reuse
  EXPECT_EQ(a.spare_count(), 0U);
  for (int i = 0; i < 3; ++i) a.recycle(std::vector<PointXYZIRT>(4));
  EXPECT_EQ(a.spare_count(), 2U);
}

TEST(ScanAssembler, SequenceNumbersCountEmittedScansOnly) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  add_packet(a, 1);
  EXPECT_EQ(a.end_scan(true)->seq, 0U);
  add_packet(a, 1);
  EXPECT_FALSE(a.end_scan(false));  // partial, not emitted
  add_packet(a, 1);
  EXPECT_EQ(a.end_scan(true)->seq, 1U);
  EXPECT_EQ(stats.scans, 2U);
  EXPECT_EQ(stats.partial_scans_discarded, 1U);
}

TEST(ScanAssembler, PartialScansAreEmittedWhenAskedFor) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8, .emit_partial_scans = true}, stats);
  add_packet(a, 2);
  const auto s = a.end_scan(false);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->points.size(), 2U);
  EXPECT_EQ(stats.partial_scans_discarded, 0U);
}

TEST(ScanAssembler, EmptyScanIsNeitherEmittedNorCounted) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  EXPECT_FALSE(a.end_scan(true));
  EXPECT_EQ(stats.scans, 0U);
  EXPECT_EQ(stats.partial_scans_discarded, 0U);
}

TEST(ScanAssembler, CountsPacketsByStatusAndCarriesDropsOfADiscardedScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  EXPECT_FALSE(a.accept(PacketStatus::kWrongSize));
  EXPECT_FALSE(a.accept(PacketStatus::kBadAzimuth));
  add_packet(a, 1);
  EXPECT_EQ(stats.packets, 3U);
  EXPECT_EQ(stats.packets_used, 1U);
  EXPECT_EQ(stats.dropped(), 2U);
  EXPECT_EQ(stats.by_status[static_cast<std::size_t>(PacketStatus::kOk)], 1U);
  EXPECT_EQ(stats.by_status[static_cast<std::size_t>(PacketStatus::kWrongSize)], 1U);
  EXPECT_EQ(stats.by_status[static_cast<std::size_t>(PacketStatus::kBadAzimuth)], 1U);
  EXPECT_EQ(a.scan().dropped, 2U);

  EXPECT_FALSE(a.end_scan(false));  // discarded: its drops stay visible in the next scan
  EXPECT_EQ(a.scan().dropped, 2U);
  EXPECT_FALSE(a.accept(PacketStatus::kNotData));
  add_packet(a, 1);
  const auto s = a.end_scan(true);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->dropped, 3U);
  EXPECT_EQ(a.scan().dropped, 0U);  // an emitted scan takes its drops with it
}

TEST(ScanAssembler, TouchStampsOnceAndCountsEachPacketOnce) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  a.begin_packet();
  a.current().touch(100, 110);
  a.current().touch(200, 110);  // same packet, later block
  a.begin_packet();
  a.current().touch(300, 310);
  const Scan& s = a.scan();
  EXPECT_EQ(s.stamp, 100);
  EXPECT_EQ(s.first_rx_ns, 110);
  EXPECT_EQ(s.last_rx_ns, 310);
  EXPECT_EQ(s.packets, 2U);
}

TEST(ScanAssembler, NextFromCutMarksTheNextScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  add_packet(a, 1);
  EXPECT_FALSE(a.end_scan(a.current().from_cut, true));  // began mid-rotation: partial
  EXPECT_TRUE(a.current().from_cut);
  add_packet(a, 1);
  EXPECT_TRUE(a.end_scan(a.current().from_cut, true));  // cut to cut: complete
}

TEST(ScanAssembler, FlushReturnsTheScanInProgressAndResets) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  EXPECT_FALSE(a.flush());  // nothing in progress
  EXPECT_EQ(stats.scans, 0U);

  add_packet(a, 4);
  a.current().from_cut = true;
  const auto s = a.flush();  // partial, emitted even though partial scans are not
  ASSERT_TRUE(s);
  EXPECT_EQ(s->points.size(), 4U);
  EXPECT_EQ(s->seq, 0U);
  EXPECT_EQ(stats.scans, 1U);
  EXPECT_EQ(stats.partial_scans_discarded, 0U);
  EXPECT_EQ(a.scan().packets, 0U);
  EXPECT_FALSE(a.current().started);
  EXPECT_FALSE(a.current().from_cut);
  EXPECT_FALSE(a.flush());
}

TEST(ScanAssembler, FlushNeedsAStampedScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  ++a.scan().packets;  // Ouster: a packet without a valid column counts but stamps nothing
  EXPECT_FALSE(a.flush());
  EXPECT_EQ(stats.partial_scans_discarded, 0U);
}

TEST(ScanAssembler, FlushReusesTheBufferOfAnEmptyScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8}, stats);
  const PointXYZIRT* before = a.scan().points.data();
  ASSERT_NE(before, nullptr);
  EXPECT_FALSE(a.flush());
  EXPECT_EQ(a.scan().points.data(), before);
}

TEST(ScanAssembler, ReservesTheLastScanPlusAnEighthUpToTheCap) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 16, .max_reserve = 100}, stats);
  EXPECT_GE(a.scan().points.capacity(), 16U);
  add_packet(a, 40);
  ASSERT_TRUE(a.end_scan(true));
  EXPECT_GE(a.scan().points.capacity(), 45U);  // 40 + 40 / 8
  add_packet(a, 96);
  ASSERT_TRUE(a.end_scan(true));
  EXPECT_GE(a.scan().points.capacity(), 100U);
  EXPECT_LT(a.scan().points.capacity(), 108U);  // capped, not 96 + 12
}

TEST(ScanAssembler, LookaheadScanBecomesCurrent) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8, .spare_buffers = 3, .lookahead = true}, stats);
  add_packet(a, 2);
  a.next().touch(2000, 2005);
  a.next().from_cut = true;
  a.next().scan.points.push_back(PointXYZIRT{});
  const auto s = a.end_scan(true);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->points.size(), 2U);
  EXPECT_EQ(a.scan().stamp, 2000);
  EXPECT_EQ(a.scan().points.size(), 1U);
  EXPECT_TRUE(a.current().from_cut);
  EXPECT_EQ(a.next().scan.packets, 0U);
  EXPECT_FALSE(a.next().started);
}

TEST(ScanAssembler, DropNextAndFlushDiscardTheLookahead) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8, .spare_buffers = 3, .lookahead = true}, stats);
  a.next().touch(2000, 2005);
  a.drop_next();
  EXPECT_EQ(stats.partial_scans_discarded, 1U);
  EXPECT_EQ(a.next().scan.packets, 0U);
  a.next().touch(3000, 3005);
  EXPECT_FALSE(a.flush());  // flush discards without counting
  EXPECT_EQ(stats.partial_scans_discarded, 1U);
  EXPECT_EQ(a.next().scan.packets, 0U);
}

TEST(ScanAssembler, MergeKeepsTheLaterScan) {
  ScanStats stats;
  ScanAssembler a({.first_reserve = 8, .emit_partial_scans = true}, stats);
  std::optional<Scan> out;
  add_packet(a, 1);
  a.merge(out, a.end_scan(false));  // time jump: partial, emitted
  ASSERT_TRUE(out);
  add_packet(a, 2);
  a.merge(out, a.end_scan(true));  // then a cut in the same packet
  ASSERT_TRUE(out);
  EXPECT_EQ(out->points.size(), 2U);
  EXPECT_EQ(stats.scans, 1U);
  EXPECT_EQ(stats.partial_scans_discarded, 1U);
  EXPECT_EQ(a.spare_count(), 1U);  // the dropped scan's buffer is kept for reuse
  a.merge(out, std::nullopt);
  EXPECT_EQ(out->points.size(), 2U);
}

TEST(ScanAssembler, TimeJumps) {
  constexpr Nanos kGap = 1'000'000'000;
  EXPECT_FALSE(is_time_jump(5'000'000'000, 5'000'000'000, kGap));
  EXPECT_FALSE(is_time_jump(5'000'000'000, 6'000'000'000, kGap));
  EXPECT_TRUE(is_time_jump(5'000'000'000, 6'000'000'001, kGap));
  EXPECT_FALSE(is_time_jump(5'000'000'000, 4'999'000'000, kGap));  // 1 ms back: jitter
  EXPECT_TRUE(is_time_jump(5'000'000'000, 4'998'999'999, kGap));
}

// Receive times across a host clock step: the step between two packets is CLOCK_MONOTONIC's where
// both have it, so a freeze's 1.44 s stays 1.44 s with CLOCK_REALTIME stepped 37 s under it.
TEST(ScanAssembler, ReceiveGapsAreMonotonicWhereKnown) {
  constexpr Nanos kStep = 37'000'000'000;
  const RxTimes before{100 * kSec, 10 * kSec}, after{100 * kSec + 1'440'000'000 - kStep, 10 * kSec + 1'440'000'000};
  EXPECT_EQ(receive_gap(after, before), 1'440'000'000);
  EXPECT_FALSE(is_time_jump(0, 1'440'000'000, kSec, receive_gap(after, before))) << "a freeze the receive times confirm";
  EXPECT_EQ(sensor_step_within_receive(1'440'000'000, after, before), 1'440'000'000);
  // Without the monotonic times (a capture): CLOCK_REALTIME's, unknown when it stepped back.
  EXPECT_EQ(receive_gap(RxTimes{after.real, 0}, RxTimes{before.real, 0}), -1);
  EXPECT_EQ(receive_gap(RxTimes{before.real + 5, 0}, RxTimes{before.real, 0}), 5);
  EXPECT_EQ(receive_gap(RxTimes{after.real, after.mono}, RxTimes{before.real, 0}), -1) << "one unknown: CLOCK_REALTIME's, stepped back";
  EXPECT_EQ(receive_gap(RxTimes{1, 5}, RxTimes{1, 9}), -1) << "monotonic never steps back: unknown";
  // One corrupt time still bounded by the receive step.
  EXPECT_EQ(sensor_step_within_receive(3'600 * kSec, RxTimes{0, 10 * kSec + 1'000'000}, RxTimes{0, 10 * kSec}), 2'000'000);
}

// A kernel stamp on CLOCK_MONOTONIC by the clocks as read after it: unknown (0) when a step between
// the two puts it after the read or more than 2 s before.
TEST(ScanAssembler, MonotonicReceiveTimeByTheReadsClocks) {
  constexpr Nanos kOffset = 1'000 * kSec;  // realtime - monotonic at the read
  EXPECT_EQ(monotonic_receive_ns(kOffset + 50 * kSec - 300'000, kOffset, 50 * kSec), 50 * kSec - 300'000);
  EXPECT_EQ(monotonic_receive_ns(kOffset + 50 * kSec + 2'000'000, kOffset, 50 * kSec), 0) << "after the read: stepped back since";
  EXPECT_EQ(monotonic_receive_ns(kOffset + 47 * kSec, kOffset, 50 * kSec), 0) << "3 s before: stepped forward since";
  EXPECT_EQ(monotonic_receive_ns(0, kOffset, 50 * kSec), 0);
}

}  // namespace
}  // namespace sensor_rig::lidar
