// The LIDAR node with `source: packet`: the config keys (errors at file:line:col), an unknown
// interface refused at start naming the LIDAR, and a synthetic VLP-16 sent over loopback read
// through the AF_PACKET ring into published scans, with the ring's counters in the status; its
// recording keeps the IPv4/UDP headers the ring captured.
#include <gtest/gtest.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "rig_process.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "status_value.hpp"
#include "wait.hpp"
#include "wait_bounds.hpp"

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

// record.queue_mb: how far the recording's writer may fall behind (MiB, 1..4096, default 16).
TEST(LidarConfig, RecordQueueSize) {
  const auto ok = parse(kHead + "record: {directory: rec, queue_mb: 64}\n");
  ASSERT_TRUE(ok.problems.empty()) << ok.problems.front().str();
  EXPECT_DOUBLE_EQ(ok.config.record.queue_mb, 64.0);
  EXPECT_DOUBLE_EQ(parse(kHead + "record: {directory: rec}\n").config.record.queue_mb, 16.0);
  const auto bad = parse(kHead + "record: {directory: rec, queue_mb: 0.5}\n");
  ASSERT_EQ(bad.problems.size(), 1u);
  EXPECT_EQ(bad.problems.front().line, 4) << bad.problems.front().str();
  EXPECT_NE(bad.problems.front().key.find("queue_mb"), std::string::npos) << bad.problems.front().str();
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

// The driver on the packet ring, or null with the reason when AF_PACKET is not permitted here.
std::unique_ptr<LidarDriver> ring_driver(const LidarConfig& c, dds::Participant& p, dds::StampsWriter& stamps,
                                         std::string& why) {
  try {
    return std::make_unique<LidarDriver>(c, p, stamps);
  } catch (const std::runtime_error& e) {
    why = std::string("AF_PACKET ring not permitted here: ") + e.what();
    return nullptr;
  }
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
  std::string why;
  const auto driver = ring_driver(c, p, stamps, why);
  if (!driver) GTEST_SKIP() << why;
  driver->start();
  ASSERT_TRUE(reader.wait_for_writers(1, test::kDiscoveryMs));

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


// The IPv4 header bytes of every record of a pcap file the recorder wrote (Ethernet frames).
std::vector<std::vector<std::byte>> recorded_ipv4_headers(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  const std::vector<char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto le32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(i)]);
    return v;
  };
  std::vector<std::vector<std::byte>> out;
  for (std::size_t at = 24; at + 16 + 14 + 20 <= b.size(); at += 16 + le32(at + 8)) {
    const auto* ip = reinterpret_cast<const std::byte*>(b.data() + at + 16 + 14);
    out.emplace_back(ip, ip + 20);
  }
  return out;
}

// The ring sees each datagram's own headers, and the recording keeps them: sent to 127.0.0.2 (not
// the configured host) with a DSCP mark from a known port, every record says so (before, the
// recorder rebuilt them from the config: destination 127.0.0.1, TOS 0).
TEST(LidarPacketSource, RecordingKeepsTheCapturedHeaders) {
  test::TempDir dir;
  auto c = vlp16_on("lo", "ringrec");
  c.record.directory = (dir.path / "rec").string();
  dds::Participant p;
  dds::StampsWriter stamps(p);
  std::string why;
  const auto driver = ring_driver(c, p, stamps, why);
  if (!driver) GTEST_SKIP() << why;
  driver->start();
  UniqueFd tx(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  ASSERT_TRUE(tx);
  const int tos = 0x28;  // DSCP AF11
  ASSERT_EQ(::setsockopt(tx.get(), IPPROTO_IP, IP_TOS, &tos, sizeof tos), 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  from.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(tx.get(), reinterpret_cast<const sockaddr*>(&from), sizeof from), 0);
  socklen_t len = sizeof from;
  ASSERT_EQ(::getsockname(tx.get(), reinterpret_cast<sockaddr*>(&from), &len), 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(c.port));
  to.sin_addr.s_addr = htonl(0x7F000002);

  lidar::mock::SyntheticOptions o;
  o.model = "VLP-16";
  auto s = lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
  constexpr std::size_t kSent = 20;
  for (std::size_t n = 0; n < kSent;) {
    const auto pkt = s->next();
    if (pkt.position) continue;
    ASSERT_EQ(::sendto(tx.get(), pkt.bytes.data(), pkt.bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(pkt.bytes.size()));
    ++n;
  }
  ASSERT_TRUE(test::wait_for([&] { return test::status_value(driver->status(), "record_packets") == std::to_string(kSent); },
                             5000))
      << test::status_value(driver->status(), "record_packets");
  driver->stop();

  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(c.record.directory)) files.push_back(e.path());
  ASSERT_EQ(files.size(), 1u);
  lidar::PcapReader r(files[0].string());
  std::size_t records = 0;
  while (auto rec = r.next()) {
    ++records;
    EXPECT_EQ(rec->dst_ip, 0x7F000002u) << "the datagram's destination, not the configured host";
    EXPECT_EQ(rec->src_ip, 0x7F000001u);
    EXPECT_EQ(rec->src_port, ntohs(from.sin_port));
    EXPECT_EQ(rec->packet.dst_port, c.port);
    EXPECT_EQ(rec->packet.data.size(), 1206u);
  }
  EXPECT_EQ(r.error(), "");
  EXPECT_EQ(records, kSent);
  const auto headers = recorded_ipv4_headers(files[0]);
  ASSERT_EQ(headers.size(), kSent);
  for (const auto& h : headers) {
    EXPECT_EQ(std::to_integer<int>(h[1]), tos) << "the sender's TOS byte, as on the wire";
    EXPECT_EQ(lidar::ipv4_header_checksum(h), 0) << "a valid header checksum";
  }
}

}  // namespace
}  // namespace sensor_rig::drivers
