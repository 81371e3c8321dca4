// The ring source's classic BPF program, run in userspace on synthetic IPv4 packets (the kernel
// runs the same instructions; test_lidar_udp checks it on a real socket): UDP to the sensor's port
// and UDP fragments pass, everything else is rejected; with a sensor address, only its packets.
#include <gtest/gtest.h>

#include "ipv4_packets.hpp"
#include "sensor_rig/lidar/packet_filter.hpp"

namespace sensor_rig::lidar {
namespace {

using test::Bytes;
using test::Ip;

Bytes udp_to(std::uint16_t port, const Ip& ip = {}) {
  return test::ipv4_packet(ip, 0, false, test::udp_segment(40000, port, test::payload_of(64, 1)));
}

bool passes(const SensorFilter& f, const Bytes& pkt) {
  const auto prog = build_sensor_filter(f);
  return run_classic_bpf(prog, pkt) != 0;
}

TEST(PacketFilter, UdpToTheSensorPortOnly) {
  const SensorFilter f{7502, 0};
  EXPECT_TRUE(passes(f, udp_to(7502)));
  EXPECT_FALSE(passes(f, udp_to(7503)));
  EXPECT_FALSE(passes(f, udp_to(2368)));
  Ip tcp;
  tcp.proto = 6;
  EXPECT_FALSE(passes(f, udp_to(7502, tcp)));
  EXPECT_EQ(run_classic_bpf(build_sensor_filter(f), udp_to(7502)), kFilterAcceptBytes);
}

// One ring per sensor for both ports: the second (IMU / position) port passes too, nothing else.
TEST(PacketFilter, SecondPortPassesToo) {
  const SensorFilter f{7502, 0, 7503};
  EXPECT_TRUE(passes(f, udp_to(7502)));
  EXPECT_TRUE(passes(f, udp_to(7503)));
  EXPECT_FALSE(passes(f, udp_to(7504)));
  EXPECT_FALSE(passes(f, udp_to(2368)));
  Ip opts;
  opts.header_bytes = 32;
  EXPECT_TRUE(passes(f, udp_to(7503, opts)));
  const Ip ip;
  EXPECT_TRUE(passes({7502, ip.src, 7503}, udp_to(7503)));
  EXPECT_FALSE(passes({7502, ip.src + 1, 7503}, udp_to(7503))) << "another sender";
}

TEST(PacketFilter, PortIsFoundBehindHeaderOptions) {
  Ip opts;
  opts.header_bytes = 32;
  EXPECT_TRUE(passes({7502, 0}, udp_to(7502, opts)));
  EXPECT_FALSE(passes({7502, 0}, udp_to(7503, opts)));
}

TEST(PacketFilter, FragmentsPassBySenderTheReassemblerDecides) {
  const Ip ip;
  const auto frags = test::fragments(ip, test::udp_segment(40000, 7502, test::payload_of(4000, 2)), 1480);
  ASSERT_EQ(frags.size(), 3u);
  for (const auto& fr : frags) EXPECT_TRUE(passes({7502, 0}, fr));
  // Another port's fragments pass too (later ones cannot be told apart); not a TCP fragment.
  const auto other = test::fragments(ip, test::udp_segment(40000, 9999, test::payload_of(4000, 2)), 1480);
  EXPECT_TRUE(passes({7502, 0}, other[0]));
  EXPECT_TRUE(passes({7502, 0}, other[2]));
  Ip tcp = ip;
  tcp.proto = 6;
  EXPECT_FALSE(passes({7502, 0}, test::fragments(tcp, test::payload_of(4000, 2), 1480)[1]));
  // With the sensor's address: another sender's later fragments are rejected too.
  EXPECT_TRUE(passes({7502, ip.src}, frags[1]));
  EXPECT_FALSE(passes({7502, ip.src + 1}, frags[1]));
  EXPECT_FALSE(passes({7502, ip.src + 1}, frags[0]));
}

TEST(PacketFilter, ShortPacketsAreRejectedNotReadPastTheEnd) {
  const SensorFilter f{7502, 0};
  auto pkt = udp_to(7502);
  for (std::size_t n : {0u, 9u, 20u, 21u, 23u}) {
    const Bytes cut(pkt.begin(), pkt.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_FALSE(passes(f, cut)) << n << " bytes";
  }
  EXPECT_TRUE(passes(f, Bytes(pkt.begin(), pkt.begin() + 24))) << "the port is in bytes 22-23";
}

TEST(PacketFilter, ProgramShape) {
  // Jumps stay inside the program and it ends in returns: what the kernel's checker requires.
  for (const SensorFilter f : {SensorFilter{2368, 0}, SensorFilter{2368, 0xc0a80101}}) {
    const auto prog = build_sensor_filter(f);
    ASSERT_GE(prog.size(), 2u);
    for (std::size_t i = 0; i < prog.size(); ++i)
      if (BPF_CLASS(prog[i].code) == BPF_JMP) {
        EXPECT_LT(i + 1 + prog[i].jt, prog.size());
        EXPECT_LT(i + 1 + prog[i].jf, prog.size());
      }
    EXPECT_EQ(prog.back().code, BPF_RET | BPF_K);
    EXPECT_EQ(prog.back().k, 0u);
  }
}

}  // namespace
}  // namespace sensor_rig::lidar
