// pcap reading (crafted files: Ethernet, VLAN, Linux SLL, fragments, truncation, corruption; the
// shared captures) and the PCD writer/reader.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/pcd.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"
#include "rig_process.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::test {
namespace {

using Bytes = std::vector<std::uint8_t>;

void put32(Bytes& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
void be16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v));
}

// IPv4 + UDP datagram carrying `payload`.
Bytes ipv4_udp(const Bytes& payload, std::uint16_t dport, std::uint16_t frag = 0, std::uint8_t proto = 17) {
  Bytes b;
  const auto total = static_cast<std::uint16_t>(20 + 8 + payload.size());
  b.push_back(0x45);
  b.push_back(0);
  be16(b, total);
  be16(b, 1);
  be16(b, frag);
  b.push_back(64);
  b.push_back(proto);
  be16(b, 0);
  for (int x : {192, 168, 1, 201, 255, 255, 255, 255}) b.push_back(static_cast<std::uint8_t>(x));
  be16(b, 2368);
  be16(b, dport);
  be16(b, static_cast<std::uint16_t>(8 + payload.size()));
  be16(b, 0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}
Bytes ethernet(const Bytes& ip, std::uint16_t type = 0x0800, bool vlan = false) {
  Bytes b(12, 0xAA);
  if (vlan) {
    be16(b, 0x8100);
    be16(b, 7);
  }
  be16(b, type);
  b.insert(b.end(), ip.begin(), ip.end());
  return b;
}
Bytes sll(const Bytes& ip) {
  Bytes b(14, 0);
  be16(b, 0x0800);
  b.insert(b.end(), ip.begin(), ip.end());
  return b;
}

struct PcapFile {
  Bytes bytes;
  explicit PcapFile(std::uint32_t linktype) {
    put32(bytes, 0xA1B2C3D4);
    put16(bytes, 2);
    put16(bytes, 4);
    put32(bytes, 0);
    put32(bytes, 0);
    put32(bytes, 65535);
    put32(bytes, linktype);
  }
  void record(const Bytes& frame, std::uint32_t sec, std::uint32_t usec) {
    put32(bytes, sec);
    put32(bytes, usec);
    put32(bytes, static_cast<std::uint32_t>(frame.size()));
    put32(bytes, static_cast<std::uint32_t>(frame.size()));
    bytes.insert(bytes.end(), frame.begin(), frame.end());
  }
  std::string write(const std::string& name) const {
    // One folder for the process, removed when it ends (a failed test's files too).
    static const ::sensor_rig::test::TempDir dir;
    auto path = (dir.path / name).string();
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                               static_cast<std::streamsize>(bytes.size()));
    return path;
  }
};

Bytes payload(std::size_t n, std::uint8_t seed) {
  Bytes p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(seed + i);
  return p;
}

TEST(PcapReader, EthernetFramesAndCounters) {
  PcapFile f(1);
  f.record(ethernet(ipv4_udp(payload(1206, 1), 2368)), 100, 250);
  f.record(ethernet(Bytes(28, 0), 0x0806), 100, 300);                 // ARP
  f.record(ethernet(ipv4_udp(payload(100, 2), 2368, 0x2000)), 100, 400);  // first fragment
  f.record(ethernet(ipv4_udp(payload(10, 3), 53, 0, 6)), 100, 450);       // TCP
  f.record(ethernet(ipv4_udp(payload(512, 4), 8308), 0x0800, true), 101, 5);  // VLAN-tagged
  Bytes padded = ethernet(ipv4_udp(payload(4, 5), 9999));
  padded.resize(60, 0);  // Ethernet minimum-size padding after the datagram
  f.record(padded, 101, 6);
  PcapReader r(f.write("eth.pcap"));
  EXPECT_EQ(r.linktype(), 1);
  auto a = r.next();
  ASSERT_TRUE(a);
  EXPECT_EQ(a->packet.data.size(), 1206U);
  EXPECT_EQ(std::to_integer<int>(a->packet.data[5]), 6);
  EXPECT_EQ(a->packet.dst_port, 2368);
  EXPECT_EQ(a->packet.rx_ns, 100'000'250'000);
  EXPECT_EQ(a->src_ip, 0xC0A801C9U);
  auto b = r.next();
  ASSERT_TRUE(b);
  EXPECT_EQ(b->packet.data.size(), 512U);
  EXPECT_EQ(b->packet.dst_port, 8308);
  auto c = r.next();
  ASSERT_TRUE(c);
  EXPECT_EQ(c->packet.data.size(), 4U);
  EXPECT_FALSE(r.next());
  EXPECT_TRUE(r.error().empty()) << r.error();
  EXPECT_EQ(r.stats().records, 6U);
  EXPECT_EQ(r.stats().udp, 3U);
  EXPECT_EQ(r.stats().not_udp, 2U);
  EXPECT_EQ(r.stats().fragments, 1U);
}

TEST(PcapReader, LinuxCookedCapture) {
  PcapFile f(113);
  f.record(sll(ipv4_udp(payload(1206, 9), 2368)), 5, 0);
  PcapReader r(f.write("sll.pcap"));
  auto a = r.next();
  ASSERT_TRUE(a);
  EXPECT_EQ(a->packet.data.size(), 1206U);
  EXPECT_EQ(std::to_integer<int>(a->packet.data[0]), 9);
}

TEST(PcapReader, TruncatedFileEndsWithAnErrorNotACrash) {
  PcapFile f(1);
  for (int i = 0; i < 3; ++i) f.record(ethernet(ipv4_udp(payload(1206, 1), 2368)), 100, static_cast<std::uint32_t>(i));
  Bytes cut = f.bytes;
  cut.resize(cut.size() - 500);
  PcapFile g(1);
  g.bytes = cut;
  PcapReader r(g.write("cut.pcap"));
  int n = 0;
  while (r.next()) ++n;
  EXPECT_EQ(n, 2);
  EXPECT_NE(r.error().find("truncated"), std::string::npos) << r.error();
  EXPECT_FALSE(r.next());  // stays ended
}

TEST(PcapReader, CorruptOrMissingFilesThrowClearly) {
  PcapFile junk(1);
  junk.bytes.assign(64, 0x5A);
  try {
    PcapReader r(junk.write("junk.pcap"));
    FAIL() << "no error";
  } catch (const PcapError& e) {
    EXPECT_NE(std::string(e.what()).find("junk.pcap"), std::string::npos) << e.what();
  }
  EXPECT_THROW(PcapReader("/nonexistent/x.pcap"), PcapError);
  PcapFile wifi(105);
  try {
    PcapReader r(wifi.write("wifi.pcap"));
    FAIL() << "no error";
  } catch (const PcapError& e) {
    EXPECT_NE(std::string(e.what()).find("not supported"), std::string::npos) << e.what();
  }
  // A record header claiming a huge length is rejected by libpcap as an error, not read.
  PcapFile huge(1);
  put32(huge.bytes, 1);
  put32(huge.bytes, 0);
  put32(huge.bytes, 0x7FFFFFFF);
  put32(huge.bytes, 0x7FFFFFFF);
  PcapReader r(huge.write("huge.pcap"));
  EXPECT_FALSE(r.next());
  EXPECT_FALSE(r.error().empty());
}

TEST(UdpFrame, HeaderChecks) {
  const Bytes ip = ipv4_udp(payload(20, 0), 2368);
  auto bad_len = ip;
  bad_len[20 + 4] = 0xFF;  // UDP length beyond the datagram
  const auto span = [](const Bytes& b) { return std::as_bytes(std::span(b)); };
  EXPECT_EQ(parse_udp_frame(101, span(bad_len)).status, FrameStatus::kBadHeader);
  EXPECT_EQ(parse_udp_frame(101, span(ip).first(30)).status, FrameStatus::kTruncated);
  EXPECT_EQ(parse_udp_frame(101, span(ip)).status, FrameStatus::kOk);
  EXPECT_EQ(parse_udp_frame(1, span(ip).first(5)).status, FrameStatus::kTruncated);
  EXPECT_EQ(parse_udp_frame(42, span(ip)).status, FrameStatus::kUnsupportedLink);
  auto v6 = ip;
  v6[0] = 0x60;
  EXPECT_EQ(parse_udp_frame(101, span(v6)).status, FrameStatus::kNotIpv4);
  auto later_fragment = ipv4_udp(payload(20, 0), 2368, 0x0010);
  EXPECT_EQ(parse_udp_frame(101, span(later_fragment)).status, FrameStatus::kFragment);
  EXPECT_STREQ(to_string(FrameStatus::kFragment), "fragment");
}

TEST(PcapReader, SharedCaptureCounts) {
  const std::string path = velodyne_file("vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap");
  if (!exists(path)) GTEST_SKIP() << path << " not found (set RIG_TEST_DATA)";
  PcapReader r(path);
  std::size_t data = 0, position = 0;
  Nanos prev = 0;
  while (auto rec = r.next()) {
    EXPECT_GE(rec->packet.rx_ns, prev);
    prev = rec->packet.rx_ns;
    if (rec->packet.dst_port == 2368 && rec->packet.data.size() == 1206) ++data;
    if (rec->packet.dst_port == 8308 && rec->packet.data.size() == 512) ++position;
  }
  EXPECT_TRUE(r.error().empty()) << r.error();
  EXPECT_EQ(data, 1902U);
  EXPECT_EQ(position, 367U);
}

TEST(Pcd, RoundTripAndHeader) {
  std::vector<PointXYZIRT> pts;
  for (std::uint32_t i = 0; i < 100; ++i) {
    pts.push_back({static_cast<float>(i) * 0.5F, -1.25F, 3.0F, static_cast<float>(i % 256), i * 1000U,
                   static_cast<std::uint16_t>(i % 16), static_cast<std::uint8_t>(i % 4), 0});
  }
  const std::string bytes = encode_pcd(pts);
  EXPECT_EQ(bytes.rfind("# .PCD v0.7", 0), 0U);
  EXPECT_NE(bytes.find("\nFIELDS x y z intensity t ring return_type\n"), std::string::npos);
  EXPECT_NE(bytes.find("\nTYPE F F F F U U U\n"), std::string::npos);
  EXPECT_NE(bytes.find("\nWIDTH 100\nHEIGHT 1\n"), std::string::npos);
  EXPECT_NE(bytes.find("\nPOINTS 100\nDATA binary\n"), std::string::npos);
  const auto header_end = bytes.find("DATA binary\n") + 12;
  EXPECT_EQ(bytes.size() - header_end, 100U * 23U);
  const auto back = decode_pcd(bytes, "mem");
  ASSERT_EQ(back.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison): the PCD holds the points byte for byte
    EXPECT_EQ(std::memcmp(&back[i], &pts[i], sizeof(PointXYZIRT)), 0) << i;
  }
  const auto dir = std::filesystem::temp_directory_path() / ("rig_pcd_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_pcd((dir / "a.pcd").string(), pts);
  EXPECT_EQ(read_pcd((dir / "a.pcd").string()).size(), 100U);
  write_pcd((dir / "empty.pcd").string(), {});
  EXPECT_TRUE(read_pcd((dir / "empty.pcd").string()).empty());
  EXPECT_THROW(decode_pcd(bytes.substr(0, bytes.size() - 5), "short"), PcdError);
  EXPECT_THROW(decode_pcd("VERSION 0.7\nFIELDS x y z\n", "fields"), PcdError);
  EXPECT_THROW(write_pcd("/nonexistent-dir/a.pcd", pts), PcdError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sensor_rig::lidar::test
