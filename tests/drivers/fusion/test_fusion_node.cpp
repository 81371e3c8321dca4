// The fusion node through DDS in one process: scans handed over as the LIDAR nodes do
// (ScanObserver) come out as one PointCloud2 on rt/sensors/lidar/fused/points in base_link, with
// the fused layout, source ids and times re-based on the earliest scan, its stamps on
// rt/rig/stamps (last input on the wire -> fused on the wire); a dead LIDAR's sweep goes out as
// a subset after the timeout, reported in the node's status; a LIDAR that stops costs one timeout,
// the later sweeps go out without waiting for it, and their stamps count its scan as missing packets.
// Every sweep's members (rt/rig/sets/fused: topic, stamp, seq of each scan fused; set_seq = the
// cloud's seq) are held against the scans the test handed over.
// The fixed topic names: a leased DDS domain.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <ostream>
#include <string>
#include <vector>

#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/fusion/fused_point.hpp"
#include "sensor_rig/drivers/fusion/fusion_node.hpp"
#include "dds_domain_lease.hpp"
#include "status_value.hpp"
#include "wait.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::drivers {
namespace {

using test::status_value;
using test::wait_for;

struct FusedSeen {
  Nanos stamp = 0;
  std::string frame;
  std::vector<std::string> fields;
  std::uint32_t point_step = 0;
  std::vector<FusedPoint> points;
};

// One member of a fused sweep as published: (topic, stamp, seq on /rig/stamps).
struct MemberSeen {
  std::string topic;
  Nanos stamp = 0;
  std::uint64_t seq = 0;
  bool operator==(const MemberSeen&) const = default;
};
std::ostream& operator<<(std::ostream& o, const MemberSeen& m) { return o << m.topic << "@" << m.stamp << "#" << m.seq; }

struct SetSeen {
  Nanos stamp = 0;
  std::uint64_t set_seq = 0;
  std::string frame;
  std::vector<MemberSeen> members;
};

struct StampsSeen {
  Nanos acquisition = 0, last_rx = 0, written = 0;
  std::uint64_t seq = 0;
  std::uint32_t packets = 0, missing_packets = 0;
};

LidarConfig lidar(const std::string& name, Extrinsics e) {
  LidarConfig c;
  c.name = name;
  c.extrinsics = e;
  return c;
}

lidar::Scan scan(Nanos stamp, float x, std::size_t n, std::uint32_t packets = 10, std::uint64_t seq = 0) {
  lidar::Scan s;
  s.stamp = stamp;
  s.seq = seq;
  s.first_rx_ns = stamp + 1000;
  s.packets = packets;
  for (std::size_t i = 0; i < n; ++i)
    s.points.push_back({x, static_cast<float>(i), 0.0F, 1.0F, static_cast<std::uint32_t>(1000 * i), 0, 1, 0});
  return s;
}

class FusionNodeDds : public ::testing::Test {
 protected:
  FusionNodeDds() : pub_(domain()), sub_(domain()), stamps_writer_(pub_), fused_topic_(sub_, kFusedTopic, cfg().qos), fused_(sub_, fused_topic_, cfg().qos),
                    stamps_topic_(sub_, dds::kStampsTopic, dds::stamps_qos()), stamps_(sub_, stamps_topic_, dds::stamps_qos()),
                    sets_topic_(sub_, kFusedSetsTopic, sets_qos()), sets_(sub_, sets_topic_, sets_qos()) {}

  static dds::QosSpec sets_qos() {
    dds::QosSpec q;
    q.depth = 16;
    return q;
  }

  static dds::DomainConfig domain() {
    static const int leased = test::lease_dds_domain();
    dds::DomainConfig d;
    d.domain_id = static_cast<dds_domainid_t>(leased);
    return d;
  }

  static FusionConfig cfg() {
    FusionConfig c;
    c.enabled = true;
    c.max_spread_ms = 100;
    c.timeout_ms = 300;
    return c;
  }

  void drain() {
    fused_.take([this](const msg::PointCloud2& m, const auto&) {
      FusedSeen f;
      f.stamp = msg::from_time(m.header.stamp);
      f.frame = m.header.frame_id;
      for (std::uint32_t i = 0; i < m.fields._length; ++i) f.fields.emplace_back(m.fields._buffer[i].name);
      f.point_step = m.point_step;
      f.points.resize(m.width);
      if (m.data._length == m.width * sizeof(FusedPoint)) std::memcpy(f.points.data(), m.data._buffer, m.data._length);
      seen_.push_back(std::move(f));
    });
    stamps_.take([this](const msg::SourceStamps& s, const auto&) {
      if (std::string(s.topic) == kFusedTopic)
        stamped_.push_back({s.acquisition_ns, s.last_rx_ns, s.written_ns, s.seq, s.packets, s.missing_packets});
    });
    sets_.take([this](const msg::SyncSet& s, const auto&) {
      SetSeen set{msg::from_time(s.header.stamp), s.set_seq, s.header.frame_id, {}};
      for (std::uint32_t i = 0; i < s.members._length; ++i) {
        const auto& m = s.members._buffer[i];
        set.members.push_back({m.topic, msg::from_time(m.stamp), m.seq});
      }
      sets_seen_.push_back(std::move(set));
    });
  }
  // Every output's reader matched its writer (both ways for the volatile stamps): a sample written
  // before would be lost to this test, not to the node. Generous bounds for a loaded host.
  bool matched() {
    return fused_.wait_for_writers(1, test::kDiscoveryMs) && sets_.wait_for_writers(1, test::kDiscoveryMs) &&
           stamps_.wait_for_writers(1, test::kDiscoveryMs) && stamps_writer_.wait_for_readers(1, test::kDiscoveryMs);
  }
  bool wait_clouds(std::size_t n) {
    return wait_for([&] { drain(); return seen_.size() >= n && stamped_.size() >= n && sets_seen_.size() >= n; }, test::kDiscoveryMs);
  }

  dds::Participant pub_, sub_;
  dds::StampsWriter stamps_writer_;
  dds::Topic<msg::PointCloud2> fused_topic_;
  dds::Reader<msg::PointCloud2> fused_;
  dds::Topic<msg::SourceStamps> stamps_topic_;
  dds::Reader<msg::SourceStamps> stamps_;
  dds::Topic<msg::SyncSet> sets_topic_;
  dds::Reader<msg::SyncSet> sets_;
  std::vector<FusedSeen> seen_;
  std::vector<SetSeen> sets_seen_;
  std::vector<StampsSeen> stamped_;
};

TEST_F(FusionNodeDds, ThreeLidarsBecomeOneCloudInBaseLink) {
  const std::vector<LidarConfig> lidars{lidar("front", {.x = 1.0, .z = 2.0}), lidar("left", {.y = 1.0, .yaw_deg = 90}),
                                        lidar("right", {.y = -1.0, .yaw_deg = -90})};
  FusionNode node(cfg(), lidars, pub_, stamps_writer_);
  node.start();
  ASSERT_TRUE(matched());
  const Nanos t0 = vehicle_now_ns();
  // Phases 0, 30, 60 ms; each scan handed over "after its write".
  node.input(1)->observe_scan(scan(t0 + 30'000'000, 5, 3, 10, 41), t0 + 130'000'000, false);
  node.input(0)->observe_scan(scan(t0, 10, 2, 10, 7), t0 + 100'000'000, false);
  node.input(2)->observe_scan(scan(t0 + 60'000'000, 7, 4, 10, 1234), t0 + 160'000'000, false);
  ASSERT_TRUE(wait_clouds(1));
  const auto& f = seen_[0];
  EXPECT_EQ(f.frame, "base_link");
  EXPECT_EQ(f.stamp, t0);  // the earliest scan's
  EXPECT_EQ(f.point_step, 24u);
  EXPECT_EQ(f.fields, (std::vector<std::string>{"x", "y", "z", "intensity", "t", "source"}));
  ASSERT_EQ(f.points.size(), 9u);
  std::size_t per_source[3] = {0, 0, 0};
  for (const auto& p : f.points) {
    ASSERT_LT(p.source, 3);
    const std::uint32_t i = p.t % 1'000'000 / 1000;  // the point's index in its scan
    ++per_source[p.source];
    if (p.source == 0) {  // front: (10, i, 0) + (1, 0, 2)
      EXPECT_NEAR(static_cast<double>(p.x), 11, 1e-5);
      EXPECT_NEAR(static_cast<double>(p.z), 2, 1e-5);
      EXPECT_EQ(p.t, 1000 * i);
    } else if (p.source == 1) {  // left, yawed 90: (5, i, 0) -> (-i, 5 + 1, 0)
      EXPECT_NEAR(static_cast<double>(p.y), 6, 1e-5);
      EXPECT_NEAR(static_cast<double>(p.x), -static_cast<double>(i), 1e-5);
      EXPECT_EQ(p.t, 30'000'000 + 1000 * i);  // re-based on the fused stamp
    } else {  // right, yawed -90: (7, i, 0) -> (i, -7 - 1, 0)
      EXPECT_NEAR(static_cast<double>(p.y), -8, 1e-5);
      EXPECT_EQ(p.t, 60'000'000 + 1000 * i);
    }
  }
  EXPECT_EQ(per_source[0], 2u);
  EXPECT_EQ(per_source[1], 3u);
  EXPECT_EQ(per_source[2], 4u);
  ASSERT_EQ(stamped_.size(), 1u);
  EXPECT_EQ(stamped_[0].acquisition, t0);
  EXPECT_EQ(stamped_[0].last_rx, t0 + 160'000'000);  // the last input on the wire
  EXPECT_GT(stamped_[0].written, 0);
  // Its members: the three scans handed over, in config order, paired with the cloud by stamp and seq.
  ASSERT_EQ(sets_seen_.size(), 1u);
  EXPECT_EQ(sets_seen_[0].stamp, t0);
  EXPECT_EQ(sets_seen_[0].set_seq, stamped_[0].seq);
  EXPECT_EQ(sets_seen_[0].frame, "fused");
  EXPECT_EQ(sets_seen_[0].members, (std::vector<MemberSeen>{{"/sensors/lidar/front/points", t0, 7},
                                                             {"/sensors/lidar/left/points", t0 + 30'000'000, 41},
                                                             {"/sensors/lidar/right/points", t0 + 60'000'000, 1234}}));
  EXPECT_TRUE(wait_for([&] { return status_value(node.status(), "complete_sweeps") == "1"; }, 30'000));
  EXPECT_EQ(status_value(node.status(), "source_2"), "right");
}

TEST_F(FusionNodeDds, DeadLidarSweepGoesOutAsSubsetAfterTimeout) {
  const std::vector<LidarConfig> lidars{lidar("front", {}), lidar("rear", {.yaw_deg = 180})};
  FusionNode node(cfg(), lidars, pub_, stamps_writer_);
  node.start();
  ASSERT_TRUE(matched());
  const Nanos t0 = vehicle_now_ns();
  const Nanos handed = vehicle_now_ns();
  node.input(0)->observe_scan(scan(t0, 3, 5), handed, false);
  ASSERT_TRUE(wait_clouds(1));
  const Nanos waited = vehicle_now_ns() - handed;
  EXPECT_GE(waited, 290'000'000);  // the timeout (300 ms) after the sweep opened
  EXPECT_EQ(seen_[0].points.size(), 5u);
  EXPECT_EQ(seen_[0].points[0].source, 0);
  EXPECT_TRUE(wait_for([&] { return status_value(node.status(), "partial_timeout") == "1"; }, 30'000));
  const auto st = node.status();
  EXPECT_EQ(status_value(st, "missing_rear"), "1");
  EXPECT_EQ(status_value(st, "missing_front"), "0");
  EXPECT_EQ(status_value(st, "lidars_last_sweep"), "1");
  EXPECT_EQ(st.level, dds::Level::kWarn);
  EXPECT_NE(st.message.find("partial"), std::string::npos) << st.message;
}

// Rotation n of LIDAR i is stamped t0 + n * 100 ms + its phase; the right LIDAR (phase 45 ms,
// 12 packets a scan) stops after rotation 0 and comes back at rotation 4.
TEST_F(FusionNodeDds, StoppedLidarCostsOneTimeoutAndIsCountedMissing) {
  const std::vector<LidarConfig> lidars{lidar("front", {}), lidar("left", {.yaw_deg = 90}), lidar("right", {.yaw_deg = -90})};
  auto c = cfg();
  c.timeout_ms = 1000;  // far more than the test thread takes between two hand-overs, even on a loaded host
  FusionNode node(c, lidars, pub_, stamps_writer_);
  node.start();
  ASSERT_TRUE(matched());
  const Nanos t0 = vehicle_now_ns();
  const Nanos phase[3] = {0, 20'000'000, 45'000'000};
  const char* topics[3] = {"/sensors/lidar/front/points", "/sensors/lidar/left/points", "/sensors/lidar/right/points"};
  std::vector<std::vector<MemberSeen>> sent(6);  // per rotation: the scans handed over, in config order
  std::uint64_t seq[3] = {100, 200, 300};        // each LIDAR's own /rig/stamps seq
  const auto hand_over = [&](int n, std::size_t i) {
    const Nanos stamp = t0 + n * 100'000'000LL + phase[i];
    node.input(i)->observe_scan(scan(stamp, 5, 2, i == 2 ? 12 : 10, seq[i]), stamp + 100'000'000, false);
    auto& s = sent[static_cast<std::size_t>(n)];
    s.push_back({topics[i], stamp, seq[i]++});
    std::sort(s.begin(), s.end(), [](const MemberSeen& a, const MemberSeen& b) { return a.topic < b.topic; });
  };
  for (std::size_t i = 0; i < 3; ++i) hand_over(0, i);
  ASSERT_TRUE(wait_clouds(1));
  for (int n = 1; n <= 3; ++n) {  // the right one is silent
    hand_over(n, 0);
    hand_over(n, 1);
    ASSERT_TRUE(wait_clouds(static_cast<std::size_t>(n) + 1)) << "rotation " << n;
  }
  // Back; its scan first, so that no sweep is closed before it came. Each rotation's cloud awaited
  // before the next is handed over, as at 10 Hz: handed over back to back on a loaded host (a CI
  // run, the dbw security tests beside it), rotations 4 and 5 queued at the node's inputs together
  // and a sweep was cut by the next rotation's scan (7 clouds).
  for (int n = 4; n <= 5; ++n) {
    for (std::size_t i : {2, 0, 1}) hand_over(n, i);
    ASSERT_TRUE(wait_clouds(static_cast<std::size_t>(n) + 1)) << "rotation " << n;
  }
  ASSERT_EQ(seen_.size(), 6u);
  ASSERT_EQ(sets_seen_.size(), 6u);
  for (int n = 0; n < 6; ++n) {
    SCOPED_TRACE("rotation " + std::to_string(n));
    const bool whole = n == 0 || n >= 4;
    EXPECT_EQ(seen_[static_cast<std::size_t>(n)].stamp, t0 + n * 100'000'000LL);
    EXPECT_EQ(seen_[static_cast<std::size_t>(n)].points.size(), whole ? 6u : 4u);
    EXPECT_EQ(stamped_[static_cast<std::size_t>(n)].packets, whole ? 32u : 20u);
    EXPECT_EQ(stamped_[static_cast<std::size_t>(n)].missing_packets, whole ? 0u : 12u);  // the right one's scan
    // The members say the same: the scans of this rotation that were handed over, the right one's
    // absent while it was silent; the set pairs with the cloud by stamp and seq.
    const auto& set = sets_seen_[static_cast<std::size_t>(n)];
    EXPECT_EQ(set.stamp, seen_[static_cast<std::size_t>(n)].stamp);
    EXPECT_EQ(set.set_seq, stamped_[static_cast<std::size_t>(n)].seq);
    EXPECT_EQ(set.members, sent[static_cast<std::size_t>(n)]);
  }
  // Rotation 1 waited for it until the timeout; 2 and 3 went out with the left scan (a node that
  // waited for a stopped LIDAR would have timed out three times).
  EXPECT_TRUE(wait_for([&] { return status_value(node.status(), "complete_sweeps") == "3"; }, 30'000));
  const auto st = node.status();
  EXPECT_EQ(status_value(st, "partial_timeout"), "1");
  EXPECT_EQ(status_value(st, "partial_dead"), "2");
  EXPECT_EQ(status_value(st, "missing_right"), "3");
  EXPECT_EQ(status_value(st, "late_scans"), "0");
}

// The fused stamp is a member's: a sweep holding a scan whose LIDAR flagged its stamps (a host clock
// step: slewed, or the sensor's synced clock disagreeing) says so on the fused topic too; sweeps of
// unflagged scans do not.
TEST_F(FusionNodeDds, ASweepWithAFlaggedMemberFlagsTheFusedStamps) {
  const std::vector<LidarConfig> lidars{lidar("front", {}), lidar("left", {.yaw_deg = 90})};
  FusionNode node(cfg(), lidars, pub_, stamps_writer_);
  node.start();
  ASSERT_TRUE(matched());
  const Nanos t0 = vehicle_now_ns();
  const auto rotation = [&](int n, bool left_flagged) {
    const Nanos stamp = t0 + n * 100'000'000LL;
    node.input(0)->observe_scan(scan(stamp, 5, 2, 10, static_cast<std::uint64_t>(n)), stamp + 100'000'000, false);
    node.input(1)->observe_scan(scan(stamp + 30'000'000, 5, 2, 10, static_cast<std::uint64_t>(100 + n)), stamp + 130'000'000,
                                left_flagged);
  };
  rotation(0, false);
  ASSERT_TRUE(wait_clouds(1));
  ASSERT_TRUE(wait_for([&] { return status_value(node.status(), "complete_sweeps") == "1"; }, 30'000));
  EXPECT_EQ(status_value(node.status(), "stamp_sync"), "ok");
  rotation(1, true);
  ASSERT_TRUE(wait_clouds(2));
  ASSERT_TRUE(wait_for([&] { return status_value(node.status(), "complete_sweeps") == "2"; }, 30'000));
  const auto st = node.status();
  EXPECT_EQ(status_value(st, "stamp_sync"), "unsynchronized");
  EXPECT_EQ(st.level, dds::Level::kWarn);
  EXPECT_NE(st.message.find("left"), std::string::npos) << st.message;
}

}  // namespace
}  // namespace sensor_rig::drivers
