// `record:` in the LIDAR node, in one process over loopback UDP and real DDS: a synthetic VLP-16
// (data + position packets) sent to the driver is recorded as received; the recording read back
// with the pcap reader has every datagram of both ports in order, and decodes to exactly the scans
// the driver published. A recording directory that cannot be created is counted and reported
// while the driver keeps publishing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "lidar_node_reader.hpp"
#include "rig_process.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

namespace fs = std::filesystem;

struct Packet {
  std::vector<std::byte> bytes;
  bool position;
};

// `turns` revolutions of a synthetic VLP-16 at 600 rpm, position packets included.
std::vector<Packet> vlp16(double turns) {
  lidar::mock::SyntheticOptions o;
  o.model = "VLP-16";
  o.start_ns = vehicle_now_ns();
  auto s = lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
  std::vector<Packet> v;
  const auto n = static_cast<std::size_t>(turns * 75.35);
  while (v.size() < n) {
    const auto p = s->next();
    v.push_back({{p.bytes.begin(), p.bytes.end()}, p.position});
  }
  return v;
}

void send_all(const std::vector<Packet>& pkts, int port, int position_port) {
  const std::vector<lidar::Endpoint> dest{{"127.0.0.1", static_cast<std::uint16_t>(port)},
                                          {"127.0.0.1", static_cast<std::uint16_t>(position_port)}};
  lidar::UdpSender sender(dest);
  for (std::size_t i = 0; i < pkts.size(); ++i) {
    sender.send(pkts[i].bytes, pkts[i].position ? 1 : 0);
    if (i % 50 == 49) ::usleep(2000);  // within the socket buffer whatever rmem_max says
  }
}

LidarConfig vlp16_config(const std::string& name) {
  LidarConfig c;
  c.name = name + "_" + std::to_string(::getpid());
  c.model = "VLP-16";
  c.port = test::free_udp_port();
  c.position_port = test::free_udp_port();
  c.time_source = timesync::TimeSource::kHost;
  c.frame_id = "lidar_" + c.name;
  return c;
}

// The node with a reader of its clouds, and what a recording test does with them.
struct RecordingNode : test::LidarNodeReader<msg::PointCloud2> {
  explicit RecordingNode(const LidarConfig& config) : LidarNodeReader(config, "points", 50) {}
  // Points per scan of the clouds received so far (appended to `widths`).
  void take(std::vector<std::uint32_t>& widths) {
    reader.take([&](const msg::PointCloud2& m, const dds_sample_info_t&) { widths.push_back(m.width); });
  }
  // Waits for every sent packet to be recorded, taking the clouds meanwhile; then stops the node.
  [[nodiscard]] bool record_all_then_stop(std::size_t sent, std::vector<std::uint32_t>& widths) {
    const bool all = wait_for(
        [&] {
          take(widths);
          return status("record_packets") == std::to_string(sent);
        },
        5000);
    ::usleep(100'000);  // the last scan's cloud may still be on its way
    take(widths);
    driver.stop();
    return all;
  }
  // The recording's files, in name (= time) order.
  [[nodiscard]] std::vector<fs::path> files() const {
    std::vector<fs::path> v;
    for (const auto& e : fs::directory_iterator(c.record.directory)) v.push_back(e.path());
    std::sort(v.begin(), v.end());
    return v;
  }
};

TEST(LidarRecord, RecordingIsWhatArrivedAndDecodesToThePublishedScans) {
  test::TempDir dir;
  auto c = vlp16_config("rec");
  c.record.directory = (dir.path / "rec").string();
  c.record.max_file_mb = 1;  // ~800 packets a file: the recording rotates
  c.record.max_files = 100;
  c.host = "0.0.0.0";  // the recorded destination is the datagram's (IP_PKTINFO), not the bind address
  RecordingNode node(c);
  ASSERT_TRUE(node.start());
  const auto sent = vlp16(25.5);  // 2.5 s worth of packets, sent in ~0.1 s
  send_all(sent, c.port, c.position_port);
  std::vector<std::uint32_t> published;
  ASSERT_TRUE(node.record_all_then_stop(sent.size(), published)) << node.status("record_packets") << " of " << sent.size();
  EXPECT_EQ(node.status("record_errors"), "0");

  const auto files = node.files();
  ASSERT_GE(files.size(), 3u);
  std::vector<Packet> recorded;
  Nanos prev[2] = {0, 0};
  for (const auto& f : files) {
    lidar::PcapReader r(f.string());
    while (auto rec = r.next()) {
      const bool pos = rec->packet.dst_port == c.position_port;
      // Kernel receive times, in order per socket (the driver reads the two sockets in turn).
      EXPECT_GE(rec->packet.rx_ns, prev[pos ? 1 : 0]);
      prev[pos ? 1 : 0] = rec->packet.rx_ns;
      EXPECT_TRUE(pos || rec->packet.dst_port == c.port);
      EXPECT_EQ(rec->dst_ip, 0x7F000001u);
      EXPECT_EQ(rec->src_ip, 0x7F000001u);
      recorded.push_back({{rec->packet.data.begin(), rec->packet.data.end()}, pos});
    }
    EXPECT_EQ(r.error(), "") << f;
  }
  ASSERT_EQ(recorded.size(), sent.size());
  // Per port, the same datagrams in the same order (the two sockets interleave as they are read).
  for (bool pos : {false, true}) {
    std::vector<std::vector<std::byte>> a, b;
    for (const auto& x : sent)
      if (x.position == pos) a.push_back(x.bytes);
    for (const auto& x : recorded)
      if (x.position == pos) b.push_back(x.bytes);
    EXPECT_EQ(a, b) << (pos ? "position" : "data");
  }
  // The recording decodes to the scans the driver published.
  lidar::DecoderOptions o;
  o.model = "VLP-16";
  auto dec = lidar::make_decoder(o);
  std::vector<std::uint32_t> decoded;
  for (const auto& x : recorded) {
    if (x.position) continue;
    if (auto s = dec->push(lidar::PacketView{x.bytes, 0, static_cast<std::uint16_t>(c.port)}, 0))
      decoded.push_back(static_cast<std::uint32_t>(s->points.size()));
  }
  EXPECT_GE(decoded.size(), 24u);
  EXPECT_EQ(published, decoded);
}

TEST(LidarRecord, UnwritableDirectoryIsReportedAndTheDriverKeepsPublishing) {
  test::TempDir dir;
  std::ofstream(dir.path / "a_file") << "x";
  auto c = vlp16_config("recbad");
  c.record.directory = (dir.path / "a_file" / "sub").string();
  RecordingNode node(c);
  ASSERT_TRUE(node.start());
  const auto sent = vlp16(6.5);
  send_all(sent, c.port, c.position_port);
  std::vector<std::uint32_t> scans;
  ASSERT_TRUE(wait_for(
      [&] {
        node.take(scans);
        return scans.size() >= 4;
      },
      5000))
      << scans.size();
  ASSERT_TRUE(wait_for([&] { return node.status("record_dropped") == std::to_string(sent.size()); }, 30'000))
      << node.status("record_dropped");
  const auto st = node.driver.status();
  EXPECT_EQ(test::status_value(st, "record_packets"), "0");
  EXPECT_NE(test::status_value(st, "record_errors"), "0");
  EXPECT_EQ(st.level, dds::Level::kWarn);
  EXPECT_NE(st.message.find("cannot create"), std::string::npos) << st.message;
  node.driver.stop();
}

// Record on the car, decode on the desk: one recorded file through the `rig` binary's
// `rig lidar decode` gives the scans the driver published (same count, same points per scan).
TEST(LidarRecord, RigLidarDecodeOfTheRecordingGivesThePublishedScans) {
  test::TempDir dir;
  auto c = vlp16_config("recdec");
  c.record.directory = (dir.path / "rec").string();
  RecordingNode node(c);
  ASSERT_TRUE(node.start());
  const auto sent = vlp16(8.5);
  send_all(sent, c.port, c.position_port);
  std::vector<std::uint32_t> published;
  ASSERT_TRUE(node.record_all_then_stop(sent.size(), published));
  const auto files = node.files();
  ASSERT_EQ(files.size(), 1u);
  const auto [rc, out] = test::run(test::rig_bin() + " lidar decode --pcap " + files[0].string() +
                                   " --model VLP-16 --out " + (dir.path / "pcd").string() + " 2>/dev/null");
  ASSERT_EQ(rc, 0) << out;
  std::vector<std::uint32_t> decoded;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    const auto j = nlohmann::json::parse(line);
    decoded.push_back(j["points"].get<std::uint32_t>());
    EXPECT_EQ(j["missing_packets"].get<int>(), 0);
    EXPECT_EQ(j["dropped"].get<int>(), 0);
  }
  EXPECT_GE(decoded.size(), 7u);
  EXPECT_EQ(decoded, published);
}

}  // namespace
}  // namespace sensor_rig::drivers
