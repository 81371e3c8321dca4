// The LIDAR node with `source: packet`: the config keys (errors at file:line:col), an unknown
// interface refused at start naming the LIDAR, and a synthetic VLP-16 sent over loopback read
// through the AF_PACKET ring into published scans, with the ring's counters in the status.
#include <gtest/gtest.h>
#include <unistd.h>

#include <memory>
#include <vector>

#include "rig_process.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "status_value.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

struct Parsed {
  LidarConfig config;
  std::vector<config::Problem> problems;
};

Parsed parse(const std::string& yaml) {
  auto problems = std::make_shared<config::Problems>();
  const auto node = config::Node::load_string(yaml, "rig.yaml", problems);
  Parsed p{parse_lidar_config(node), {}};
  p.problems = problems->items();
  return p;
}

const std::string kHead = "name: front\nmodel: VLP-16\nport: 2368\n";  // lines 1-3

TEST(LidarPacketSourceConfig, KeysAndTheirErrors) {
  auto ok = parse(kHead + "source: packet\ninterface: eth1\nsensor_address: 192.168.1.201\nring_retire_ms: 1\n");
  ASSERT_TRUE(ok.problems.empty()) << ok.problems.front().str();
  EXPECT_EQ(ok.config.source, LidarSource::kPacket);
  EXPECT_EQ(ok.config.interface, "eth1");
  EXPECT_EQ(ok.config.sensor_address, "192.168.1.201");
  EXPECT_EQ(ok.config.ring_retire_ms, 1);
  EXPECT_EQ(parse(kHead + "source: packet\ninterface: eth1\n").config.ring_retire_ms, 4) << "default";
  EXPECT_EQ(parse(kHead).config.source, LidarSource::kUdp) << "udp is the default";

  struct Case {
    std::string tail;  // from line 4
    int line;
    std::string key, message;
  };
  const std::vector<Case> cases{
      {"interface: eth1\n", 4, "interface", "only used with source: packet"},
      {"source: udp\ninterface: eth1\n", 5, "interface", "only used with source: packet"},
      {"source: packet\n", 4, "source", "needs interface"},
      {"source: packet\ninterface: a/b\n", 5, "interface", "not a network interface name"},
      {"source: packet\ninterface: averyveryverylongname\n", 5, "interface", "not a network interface name"},
      {"source: raw\n", 4, "source", ""},
      {"source: packet\ninterface: eth1\nsensor_address: 300.1.2.3\n", 6, "sensor_address", "not an IPv4 address"},
      {"sensor_address: 10.0.0.2\n", 4, "sensor_address", "only used with source: packet"},
      {"ring_retire_ms: 2\n", 4, "ring_retire_ms", "only used with source: packet"},
      {"source: packet\ninterface: eth1\nring_retire_ms: 0\n", 6, "ring_retire_ms", ""},
      {"source: packet\ninterface: eth1\nring_retire_ms: 500\n", 6, "ring_retire_ms", ""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.tail);
    const auto p = parse(kHead + c.tail);
    ASSERT_EQ(p.problems.size(), 1u) << (p.problems.empty() ? "" : p.problems.front().str());
    const auto& e = p.problems.front();
    EXPECT_EQ(e.file, "rig.yaml");
    EXPECT_EQ(e.line, c.line) << e.str();
    EXPECT_GT(e.column, 0);
    EXPECT_NE(e.key.find(c.key), std::string::npos) << e.str();
    EXPECT_NE(e.message.find(c.message), std::string::npos) << e.str();
  }
}

// The scan-completeness keys: a FOV whose ends coincide (other than 0..360) is a typo, not a full
// turn; Ouster's window is the sensor's own; only Velodyne decoders have an azimuth convention.
TEST(LidarConfig, FovAndAzimuthErrors) {
  EXPECT_TRUE(parse(kHead + "fov: {start: 0, end: 360}\nazimuth: per-sequence\n").problems.empty());
  EXPECT_TRUE(parse(kHead + "fov: {start: 270, end: 90}\n").problems.empty()) << "a window across north";
  struct Case {
    std::string text;
    int line;
    std::string key, message;
  };
  const std::vector<Case> cases{
      {kHead + "fov: {start: 90, end: 90}\n", 4, "fov.end", "equals start"},
      {kHead + "fov: {start: 360, end: 0}\n", 4, "fov.end", "equals start"},
      {kHead + "fov: {start: 10, end: 400}\n", 4, "fov.end", ""},
      {"name: left\nmodel: OS-LEGACY\nport: 7502\nfov: {start: 0, end: 180}\nmock: {kind: synthetic}\n", 4, "fov", "Ouster"},
      {"name: right\nmodel: Pandar40P\nport: 2369\nazimuth: per-laser\n", 4, "azimuth", "only Velodyne"},
      {kHead + "azimuth: per-block\n", 4, "azimuth", ""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const auto p = parse(c.text);
    ASSERT_EQ(p.problems.size(), 1u) << (p.problems.empty() ? "" : p.problems.front().str());
    const auto& e = p.problems.front();
    EXPECT_EQ(e.line, c.line) << e.str();
    EXPECT_NE(e.key.find(c.key), std::string::npos) << e.str();
    EXPECT_NE(e.message.find(c.message), std::string::npos) << e.str();
  }
}

LidarConfig vlp16_on(const std::string& interface, const std::string& name) {
  LidarConfig c;
  c.name = name + "_" + std::to_string(::getpid());
  c.model = "VLP-16";
  c.port = test::free_udp_port();
  c.source = LidarSource::kPacket;
  c.interface = interface;
  c.time_source = timesync::TimeSource::kHost;
  c.frame_id = "lidar_" + c.name;
  return c;
}

TEST(LidarPacketSource, UnknownInterfaceIsAClearErrorAtStart) {
  dds::Participant p;
  dds::StampsWriter stamps(p);
  const auto c = vlp16_on("nosuch_if9", "noif");
  try {
    LidarDriver d(c, p, stamps);
    ADD_FAILURE() << "a driver on a missing interface must not start";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("lidar " + c.name + ": "), std::string::npos) << what;
    EXPECT_NE(what.find("'nosuch_if9' not found"), std::string::npos) << what;
  }
}

TEST(LidarPacketSource, RingOnLoopbackPublishesScans) {
  const auto c = vlp16_on("lo", "ring");
  dds::Participant p;    // the driver's
  dds::Participant sub;  // the subscriber's
  dds::StampsWriter stamps(p);
  dds::QosSpec q;
  q.depth = 50;
  dds::Topic<msg::PointCloud2> topic(sub, "/sensors/lidar/" + c.name + "/points", q);
  dds::Reader<msg::PointCloud2> reader(sub, topic, q);
  std::unique_ptr<LidarDriver> driver;
  try {
    driver = std::make_unique<LidarDriver>(c, p, stamps);
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "AF_PACKET ring not permitted here: " << e.what();
  }
  driver->start();
  ASSERT_TRUE(reader.wait_for_writers(1, 5000));

  lidar::mock::SyntheticOptions o;
  o.model = "VLP-16";
  o.start_ns = vehicle_now_ns();
  auto s = lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
  const std::vector<lidar::Endpoint> dest{{"127.0.0.1", static_cast<std::uint16_t>(c.port)}};
  lidar::UdpSender sender(dest);
  std::size_t data_packets = 0;
  while (data_packets < 754 * 2) {  // 2 s of a VLP-16 (20 turns), sent in well under a second
    const auto pkt = s->next();
    if (pkt.position) continue;
    sender.send(pkt.bytes);
    if (++data_packets % 50 == 0) ::usleep(2000);
  }
  std::size_t scans = 0;
  std::uint32_t points = 0;
  ASSERT_TRUE(test::wait_for(
      [&] {
        reader.take([&](const msg::PointCloud2& m, const dds_sample_info_t&) {
          ++scans;
          points = std::max(points, m.width);
        });
        return test::status_value(driver->status(), "packets") == std::to_string(data_packets) && scans >= 18;
      },
      5000))
      << test::status_value(driver->status(), "packets") << " of " << data_packets << " packets, " << scans << " scans";
  EXPECT_GT(points, 10000u);
  const auto st = driver->status();
  EXPECT_EQ(test::status_value(st, "source"), "packet");
  EXPECT_EQ(test::status_value(st, "packets_dropped"), "0");
  EXPECT_EQ(test::status_value(st, "ring_drops"), "0");
  EXPECT_EQ(test::status_value(st, "kernel_drops"), "0");
  EXPECT_EQ(test::status_value(st, "reassembly_dropped"), "0");
  EXPECT_EQ(test::status_value(st, "reassembly_dropped_timeout"), "0");
  EXPECT_EQ(test::status_value(st, "ring_filtered"), "0");
  EXPECT_NE(st.hardware_id.find("@lo:"), std::string::npos) << st.hardware_id;
  driver->stop();
}

}  // namespace
}  // namespace sensor_rig::drivers
