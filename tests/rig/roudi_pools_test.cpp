// The RouDi mempools `rig up` sizes for rig.dds.transport: shm (rig/src/roudi_pools.hpp): every
// large topic's samples fit a pool with the chunks its writers and readers can hold, the TOML
// RouDi reads round-trips, and a running RouDi's pools are checked against the rig's.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "rig_config.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"
#include "roudi_pools.hpp"
#include "test_data.hpp"

namespace sensor_rig::rig {
namespace {

// A VLP-32C (dual returns, synthetic at 300 rpm: four times its 10 Hz single-return points), the
// fused cloud, and a 1920x1200 Bayer camera with a colour output.
RigConfig sample_rig() {
  RigConfig cfg;
  cfg.dds.transport = dds::Transport::kShm;
  LidarConfig l;
  l.name = "front";
  l.model = "VLP-32C";
  l.returns = lidar::ReturnSelection::kDual;
  l.mock.kind = LidarMockConfig::Kind::kSynthetic;
  l.mock.rpm = 300;
  l.qos.depth = 2;
  cfg.lidars.push_back(l);
  cfg.fusion.enabled = true;
  drivers::CameraConfig c;
  c.name = "front_narrow";
  c.source.width = 1920;
  c.source.height = 1200;
  c.source.format = camera::PixelFormat::kBayerRG8;
  c.outputs.color = true;
  cfg.cameras.push_back(c);
  return cfg;
}

const Mempool* pool_for(const std::vector<Mempool>& pools, std::uint64_t sample_bytes) {
  const auto it = std::find_if(pools.begin(), pools.end(),
                               [&](const Mempool& p) { return p.size >= sample_bytes + kChunkOverhead; });
  return it == pools.end() ? nullptr : &*it;
}

TEST(RoudiPools, ChunkSizesRoundUpToAnEighthOfAnOctave) {
  EXPECT_EQ(chunk_size_for(100), kSmallPool);
  EXPECT_EQ(chunk_size_for(1 << 20), (1U << 20) + (1U << 17));  // + overhead: the next 128 kB step
  for (std::uint64_t b : {5000ULL, 1'400'000ULL, 2'880'000ULL, 6'913'024ULL}) {
    const std::uint64_t c = chunk_size_for(b);
    EXPECT_GE(c, b + kChunkOverhead) << b;
    EXPECT_LE(c, (b + kChunkOverhead) * 9 / 8 + 8) << b;
    EXPECT_EQ(c % 8, 0U) << b;
  }
}

TEST(RoudiPools, EveryLargeTopicFitsAPoolWithTheChunksItsReadersHold) {
  const RigConfig cfg = sample_rig();
  const auto loads = shm_topic_loads(cfg, 3);
  ASSERT_EQ(loads.size(), 4U);  // cloud, fused cloud, image_raw, image_color
  EXPECT_EQ(loads[0].max_sample_bytes, 60000ULL * 2 * 2 * 24 + 1024);  // 300 rpm x dual
  EXPECT_EQ(loads[0].readers, 4);  // three subscribers + the fusion node
  EXPECT_EQ(loads[1].topic, drivers::kFusedTopic);
  EXPECT_EQ(loads[2].max_sample_bytes, 1920ULL * 1200 + 1024);
  EXPECT_EQ(loads[3].max_sample_bytes, 1920ULL * 1200 * 3 + 1024);

  const auto pools = size_mempools(loads);
  ASSERT_LE(pools.size(), static_cast<std::size_t>(kMaxMempools));
  EXPECT_TRUE(std::is_sorted(pools.begin(), pools.end(), [](const Mempool& a, const Mempool& b) { return a.size < b.size; }));
  EXPECT_EQ(pools.front().size, kSmallPool);
  for (const auto& t : loads) {
    const Mempool* p = pool_for(pools, t.max_sample_bytes);
    ASSERT_NE(p, nullptr) << t.topic;
    // 1 writer loan + 4 readers x (depth 2 + 1) = 13 chunks held, x1.5 + 2.
    if (t.topic == "/sensors/lidar/front/points") {
      EXPECT_GE(p->count, 21U) << t.topic;
    }
    EXPECT_GE(p->count, static_cast<std::uint64_t>(1 + t.readers * (t.depth + 1))) << t.topic;
  }
  // The cloud and the fused cloud of one LIDAR are one size class: one pool serves both.
  EXPECT_EQ(pool_for(pools, loads[0].max_sample_bytes), pool_for(pools, loads[1].max_sample_bytes));
  EXPECT_GE(pool_for(pools, loads[0].max_sample_bytes)->count, 21U + 18U);  // the fused cloud: 3 readers

  RigConfig fixed = cfg;
  fixed.shm_mempools = {{1024, 10}, {8 << 20, 4}};
  EXPECT_EQ(rig_mempools(fixed), fixed.shm_mempools);
}

TEST(RoudiPools, TomlRoundTripsAndARunningRoudiIsChecked) {
  const std::vector<Mempool> pools = {{1024, 2048}, {16384, 512}, {1'572'864, 39}};
  const std::string toml = roudi_toml(pools, "two lines\nof comment");
  EXPECT_EQ(toml.rfind("# two lines\n# of comment\n[general]\nversion = 1\n", 0), 0U) << toml;
  EXPECT_EQ(parse_roudi_toml(toml), pools);
  const auto shipped = test::read_text(test::source_dir() / "config/iceoryx/rig-roudi.toml");
  EXPECT_EQ(parse_roudi_toml(shipped).size(), 6U) << "config/iceoryx/rig-roudi.toml";

  const auto defaults = iceoryx_default_mempools();
  EXPECT_EQ(mempools_shortfall({{1024, 2048}, {16384, 512}}, defaults), "");
  // 39 chunks of 1.5 MB land in the 4 MB pool (the 1 MB one is too small), which has 10.
  const std::string short_of = mempools_shortfall(pools, defaults);
  EXPECT_NE(short_of.find("the 4194304 B pool has 10 chunks, this rig needs 39"), std::string::npos) << short_of;
  const std::string too_big = mempools_shortfall({{8'388'864, 4}}, defaults);
  EXPECT_NE(too_big.find("no pool holds 8388864 B chunks (largest 4194304 B)"), std::string::npos) << too_big;
  EXPECT_EQ(roudi_config_file_of(-1), "");
}

// A synthetic Ouster without metadata is sized from the nominal sensor its mock renders (32 beams,
// 1024 columns at 600 or 1200 rpm, one echo), not as the largest Ouster frame (128 x 2048): the
// mock rig asked for 436 MB of /dev/shm. Without metadata and not synthetic the maximum stays.
TEST(RoudiPools, SyntheticOusterWithoutMetadataIsSizedAsItsMockSends) {
  RigConfig cfg;
  cfg.dds.transport = dds::Transport::kShm;
  LidarConfig l;
  l.name = "roof";
  l.model = "OS";
  l.returns = lidar::ReturnSelection::kDual;  // the nominal profile has one echo
  l.mock.kind = LidarMockConfig::Kind::kSynthetic;
  l.mock.rpm = 1200;
  cfg.lidars.push_back(l);
  l.name = "replayed";
  l.mock.kind = LidarMockConfig::Kind::kReplay;
  cfg.lidars.push_back(l);
  const auto loads = shm_topic_loads(cfg, 1);
  ASSERT_EQ(loads.size(), 2U);
  EXPECT_EQ(loads[0].max_sample_bytes, 1024ULL * 32 * 24 + 1024);
  EXPECT_EQ(loads[1].max_sample_bytes, 2048ULL * 128 * 2 * 24 + 1024);
}

// A real Velodyne is sized for the speed it is set to (`rpm`), or for the slowest it can be set to
// when the config does not say: sized at 600 rpm, a sensor set to 300 rpm sent scans of twice the
// points and every write failed (issue 26 item 7). The truth here is the sensor's physics, not the
// model table the code sizes from: a block of 32 firings every block_us whatever the speed, so a
// rotation at R rpm carries 60/R s of blocks.
TEST(RoudiPools, RealVelodynesAreSizedForTheSpeedTheyAreSetTo) {
  const auto points_per_rotation = [](const std::string& model, int rpm) {
    const auto& info = lidar::velodyne::model_info(*lidar::velodyne::model_from_name(model));
    return static_cast<std::uint64_t>(60.0 / rpm / (info.block_us * 1e-6) * 32.0);
  };
  for (const std::string model : {"VLP-16", "VLP-32C", "HDL-32E"}) {
    RigConfig cfg;
    cfg.dds.transport = dds::Transport::kShm;
    LidarConfig l;
    l.model = model;
    l.name = "unsaid";  // no mock, no rpm: a real sensor at an unknown speed
    cfg.lidars.push_back(l);
    l.name = "at600";
    l.rpm = 600;
    cfg.lidars.push_back(l);
    l.name = "at300";
    l.rpm = 300;
    cfg.lidars.push_back(l);
    const auto loads = shm_topic_loads(cfg, 1);
    ASSERT_EQ(loads.size(), 3U);
    const auto holds = [](const ShmTopicLoad& t, std::uint64_t points) { return t.max_sample_bytes >= points * 24 + 1024; };
    EXPECT_TRUE(holds(loads[0], points_per_rotation(model, 300))) << model << ": unsaid speed, " << loads[0].max_sample_bytes << " B";
    EXPECT_TRUE(holds(loads[1], points_per_rotation(model, 600))) << model;
    EXPECT_TRUE(holds(loads[2], points_per_rotation(model, 300))) << model;
    EXPECT_LT(loads[1].max_sample_bytes, loads[2].max_sample_bytes) << model << ": said 600 rpm is sized smaller";
  }
}

}  // namespace
}  // namespace sensor_rig::rig
