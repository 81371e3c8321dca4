// Synchronized sets in the rig: the `sync_sets:` config (all problems at once, file:line:col) and
// the set node (stamps in on /rig/stamps, sets out on /rig/sets/<name>) through real DDS.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "dds_domain_lease.hpp"
#include "rig_config.hpp"
#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sync_set_node.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::rig {
namespace {

std::string write_config(const std::string& body) {
  const auto path = std::filesystem::temp_directory_path() / ("sync_sets_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << body;
  return path.string();
}

constexpr const char* kRig = R"(rig: {name: t}
lidars:
  - {name: front, model: VLP-16, port: 2368}
cameras:
  - {name: left, backend: v4l2, device: /dev/video0, pixel_format: YUYV, width: 64, height: 48, frame_rate: 10}
  - {name: right, backend: v4l2, device: /dev/video1, pixel_format: YUYV, width: 64, height: 48, frame_rate: 10}
)";

TEST(SyncSetsConfig, ParsesSetsOfTheRigsTopics) {
  const auto path = write_config(std::string(kRig) + R"(sync_sets:
  - name: stereo
    members: [/sensors/camera/left/image_raw, /sensors/camera/right/image_raw]
    policy: exact
    timeout_ms: 200
  - name: front
    members: [/sensors/camera/left/image_raw, /sensors/lidar/front/points]
    max_spread_ms: 50
    min_interval_ms: 50
)");
  const auto cfg = load_rig_config(path);
  ASSERT_EQ(cfg.sync_sets.size(), 2u);
  EXPECT_EQ(cfg.sync_sets[0].name, "stereo");
  EXPECT_EQ(cfg.sync_sets[0].policy, timesync::SyncPolicy::kExact);
  EXPECT_EQ(cfg.sync_sets[0].topic(), "/rig/sets/stereo");
  const auto sc = cfg.sync_sets[1].synchronizer_config();
  EXPECT_EQ(sc.policy, timesync::SyncPolicy::kApproximate);
  EXPECT_EQ(sc.members, 2u);
  EXPECT_EQ(sc.max_spread_ns, 50'000'000);
  EXPECT_EQ(sc.timeout_ns, 500'000'000);
  EXPECT_EQ(sc.min_interval_ns, (std::vector<Nanos>{50'000'000, 50'000'000}));
  EXPECT_NE(describe(cfg).find("set front: 2 members, approximate max spread 50 ms"), std::string::npos);
  std::filesystem::remove(path);
}

TEST(SyncSetsConfig, ReportsEveryProblemWithItsPosition) {
  const auto path = write_config(std::string(kRig) + R"(sync_sets:
  - name: a
    members: [/sensors/camera/left/image_raw, /sensors/camera/nope/image_raw]
  - name: a
    members: [/sensors/camera/left/image_raw, /sensors/camera/left/image_raw]
    policy: sometimes
  - name: b
    members: [/sensors/lidar/front/points]
    max_spread_ms: -1
    colour: red
  - name: fused
    members: [/sensors/camera/left/image_raw, /sensors/camera/right/image_raw]
)");
  try {
    (void)load_rig_config(path);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path + ":9:47: sync_sets[0].members[1]: unknown member topic '/sensors/camera/nope/image_raw'"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find(path + ":10:11: sync_sets[1].name: duplicate set name 'a'"), std::string::npos) << m;
    EXPECT_NE(m.find("sync_sets[1].members[1]: member '/sensors/camera/left/image_raw' listed twice"), std::string::npos) << m;
    EXPECT_NE(m.find("sync_sets[1].policy"), std::string::npos) << m;
    EXPECT_NE(m.find("sync_sets[2].members: a set needs at least 2 members"), std::string::npos) << m;
    EXPECT_NE(m.find("sync_sets[2].max_spread_ms"), std::string::npos) << m;
    EXPECT_NE(m.find("colour"), std::string::npos) << m;
    EXPECT_NE(m.find("sync_sets[3].name: 'fused' is the fused cloud's members set"), std::string::npos) << m;
  }
  std::filesystem::remove(path);
}

// Stamps of two topics in, sets out: every complete set with the right seqs; a missing member is
// an incomplete set in the node's diagnostics.
TEST(SyncSetNode, PublishesCompleteSetsFromStampsAndCountsIncompleteOnes) {
  dds::DomainConfig dc;
  dc.domain_id = static_cast<dds_domainid_t>(sensor_rig::test::lease_dds_domain());  // away from a running rig
  dds::Participant p(dc);
  SyncSetConfig sc;
  sc.name = "pair_" + std::to_string(::getpid());
  sc.members = {"/test/a", "/test/b"};
  sc.max_spread_ms = 5;
  sc.timeout_ms = 200;
  sc.min_interval_ms = 50;
  SyncSetNode node({sc}, p);
  node.start();
  dds::QosSpec tq;
  tq.depth = 16;  // as the node's topic in this participant
  dds::QosSpec q;
  q.depth = 64;
  dds::Topic<msg::SyncSet> topic(p, sc.topic(), tq);
  dds::Reader<msg::SyncSet> reader(p, topic, q);
  dds::StampsWriter stamps(p);
  ASSERT_TRUE(reader.wait_for_writers(1, test::kDiscoveryMs));

  const Nanos t0 = vehicle_now_ns();
  char frame[] = "f";
  constexpr int kSets = 20;
  for (int k = 0; k < kSets; ++k) {
    const Nanos t = t0 + k * 100'000'000LL;
    dds::SampleStamps s{};
    stamps.write("/test/a", msg::to_time(t), frame, static_cast<std::uint64_t>(k), s);
    if (k != 7) stamps.write("/test/b", msg::to_time(t + 1'000'000), frame, 100 + static_cast<std::uint64_t>(k), s);
  }
  std::map<std::uint64_t, std::uint64_t> got;  // a seq -> b seq
  std::vector<Nanos> spreads;
  const Nanos deadline = monotonic_now_ns() + Nanos{test::kDiscoveryMs} * 1'000'000;
  while (got.size() < kSets - 1 && monotonic_now_ns() < deadline) {
    reader.wait(100);
    reader.take([&](const msg::SyncSet& m, const dds_sample_info_t&) {
      ASSERT_EQ(m.members._length, 2u);
      EXPECT_STREQ(m.members._buffer[0].topic, "/test/a");
      EXPECT_STREQ(m.members._buffer[1].topic, "/test/b");
      got[m.members._buffer[0].seq] = m.members._buffer[1].seq;
      spreads.push_back(m.spread_ns);
    });
  }
  ASSERT_EQ(got.size(), static_cast<std::size_t>(kSets - 1));
  for (const auto& [a, b] : got) EXPECT_EQ(b, a + 100);
  EXPECT_FALSE(got.contains(7));
  for (const Nanos s : spreads) EXPECT_EQ(s, 1'000'000);

  std::vector<dds::DriverStatus> st;
  node.supervise(st);
  node.stop();
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0].name, "rig/sets/" + sc.name);
  std::map<std::string, std::string> v(st[0].values.begin(), st[0].values.end());
  EXPECT_EQ(v["sets"], std::to_string(kSets - 1));
  EXPECT_EQ(v["incomplete"], "1");
  EXPECT_EQ(v["dropped"], "1");
}

}  // namespace
}  // namespace sensor_rig::rig
