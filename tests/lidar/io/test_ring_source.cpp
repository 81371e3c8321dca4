// The AF_PACKET TPACKET_V3 ring source with real sockets: on loopback (the kernel runs the BPF
// filter: other ports never reach the ring; kernel stamps; ring overflow counted through
// PACKET_STATISTICS), and across a veth pair between two network namespaces with a 1500-byte MTU,
// where datagrams up to 64 kB arrive as IPv4 fragments and come out reassembled byte for byte.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/ring_source.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "sensor_rig/lidar/udp_source.hpp"
#include "network_namespaces.hpp"

namespace sensor_rig::lidar {
namespace {

using Bytes = std::vector<std::byte>;
using sensor_rig::test::NetworkNamespaces;
using sensor_rig::test::VethPair;

Bytes ring_payload(std::size_t size, unsigned tag) {
  Bytes p(size);
  for (std::size_t i = 0; i < size; ++i) p[i] = static_cast<std::byte>((tag * 13 + i + (i >> 8)) & 0xff);
  return p;
}

struct Received {
  Bytes bytes;
  Nanos rx_ns;
  std::uint32_t src;
  Nanos rx_mono_ns = 0;
  std::uint16_t dst_port = 0;
  Bytes headers;  // the captured IPv4 + UDP headers
};

// Receives until `want` datagrams came or nothing came for `idle_limit` x 100 ms (slow hosts: a
// second while datagrams are expected; shorter when draining what is already in the ring).
std::vector<Received> receive_all(RingSource& src, std::size_t want, int idle_limit = 10) {
  SlotArena arena(16, 65536);
  std::vector<Received> got;
  int idle = 0;
  while (got.size() < want && idle < idle_limit) {
    const auto r = src.receive(arena.slots(), 100);
    if (r.status != RecvStatus::kOk) {
      ++idle;
      continue;
    }
    idle = 0;
    for (std::size_t i = 0; i < r.count; ++i) {
      const auto& s = arena.slots()[i];
      got.push_back({Bytes(s.bytes().begin(), s.bytes().end()), s.rx_ns, s.src_addr, s.rx_mono_ns, s.dst_port,
                     Bytes(s.captured_headers().begin(), s.captured_headers().end())});
    }
  }
  return got;
}

// A bound UDP socket on loopback: its port is free for the test, and the datagrams have a taker.
UdpSource sink() { return UdpSource(UdpSourceConfig{{"127.0.0.1", 0}, 1 << 20, 64, false}); }

std::optional<RingSource> ring_or_skip(const RingSourceConfig& c, std::string& why) {
  try {
    return RingSource(c);
  } catch (const std::system_error& e) {
    why = std::string("AF_PACKET ring not permitted here: ") + e.what();
    return std::nullopt;
  }
}

TEST(RingSource, LoopbackFilterStampsAndCounters) {
  auto taker = sink();
  auto other = sink();
  RingSourceConfig c;
  c.interface = "lo";
  c.port = taker.port();
  c.block_bytes = 256 << 10;
  c.block_count = 4;
  std::string why;
  auto ring = ring_or_skip(c, why);
  if (!ring) GTEST_SKIP() << why;
  const std::vector<Endpoint> dst{{"127.0.0.1", taker.port()}, {"127.0.0.1", other.port()}};
  UdpSender tx(dst);
  const Nanos before = vehicle_now_ns(), before_mono = monotonic_now_ns();
  std::vector<Bytes> sent;
  for (unsigned k = 0; k < 20; ++k) {
    sent.push_back(ring_payload(k == 7 ? 60000 : 1206, k));  // one larger than any Ethernet frame
    ASSERT_EQ(tx.send(sent.back(), 0).sent, 1u);
    ASSERT_EQ(tx.send(ring_payload(1206, 99), 1).sent, 1u);  // another port: the kernel filter drops it
  }
  const auto got = receive_all(*ring, sent.size());
  const Nanos after = vehicle_now_ns(), after_mono = monotonic_now_ns();
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].bytes, sent[i]) << "datagram " << i;
    EXPECT_GE(got[i].rx_ns, before);
    EXPECT_LE(got[i].rx_ns, after);
    EXPECT_GE(got[i].rx_mono_ns, before_mono) << "the same instant on CLOCK_MONOTONIC";
    EXPECT_LE(got[i].rx_mono_ns, after_mono);
    EXPECT_EQ(got[i].src, 0x7f000001u);
  }
  ring->refresh_kernel_stats();
  const auto& st = ring->stats();
  EXPECT_EQ(st.packets, sent.size());
  EXPECT_EQ(st.ring_packets, sent.size()) << "other ports and our own outgoing copies never enter the ring";
  EXPECT_EQ(st.ring_drops, 0u);
  EXPECT_EQ(st.filtered, 0u);
  EXPECT_EQ(st.missing_timestamps, 0u);
  EXPECT_EQ(st.truncated, 0u);
  EXPECT_EQ(ring->receive(SlotArena(2).slots(), 0).status, RecvStatus::kTimeout);
}

TEST(RingSource, FullRingDropsAreCounted) {
  auto taker = sink();
  RingSourceConfig c;
  c.interface = "lo";
  c.port = taker.port();
  c.block_bytes = 128 << 10;  // 2 x 128 KiB: ~190 datagrams of 1206 B
  c.block_count = 2;
  std::string why;
  auto ring = ring_or_skip(c, why);
  if (!ring) GTEST_SKIP() << why;
  const std::vector<Endpoint> dst{{"127.0.0.1", taker.port()}};
  UdpSender tx(dst);
  constexpr std::size_t kSent = 1000;
  for (std::size_t i = 0; i < kSent; ++i) {
    tx.send(ring_payload(1206, static_cast<unsigned>(i)));
    if (i % 50 == 49) ::usleep(1000);  // stay under the loopback backlog: only the ring may drop
  }
  const auto got = receive_all(*ring, kSent, 3);  // all sent: the ring holds what it could
  ring->refresh_kernel_stats();
  const auto& st = ring->stats();
  EXPECT_LT(got.size(), kSent);
  EXPECT_GT(st.ring_drops, 0u);
  EXPECT_GE(st.ring_freeze_q, 1u);
  EXPECT_EQ(st.ring_packets, kSent);
  EXPECT_EQ(got.size() + st.ring_drops, kSent) << "every datagram is either received or counted";
}

TEST(RingSource, BadConfigurationThrows) {
  RingSourceConfig c;
  c.interface = "no_such_if0";
  try {
    RingSource r(c);
    ADD_FAILURE() << "an unknown interface must throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'no_such_if0' not found"), std::string::npos) << e.what();
  }
  c.interface = "lo";
  c.block_bytes = 100000;
  EXPECT_THROW(RingSource{c}, std::invalid_argument);
  c.block_bytes = 1 << 20;
  c.block_count = 1;
  EXPECT_THROW(RingSource{c}, std::invalid_argument);
  c.block_count = 4;
  c.port = 0;
  EXPECT_THROW(RingSource{c}, std::invalid_argument);
}

// Sizes around the 1472-byte fragmentation point and up to the largest UDP datagram.
const std::vector<std::size_t> kSizes{64, 1206, 1472, 1473, 2960, 8192, 24896, 33000, 65507};

std::size_t fragments_of(std::size_t payload_bytes) { return (payload_bytes + 8 + 1479) / 1480; }

// A ring on the veth end in namespace A (`c` with its interface set here) and a sender in B to
// `ports` on A's address; no sender, and `why`, when the ring is not permitted.
struct VethRing {
  std::optional<RingSource> ring;
  std::optional<UdpSender> tx;
  std::string why;
};
VethRing ring_across(const VethPair& net, RingSourceConfig c, const std::vector<std::uint16_t>& ports) {
  VethRing v;
  c.interface = net.if_a();
  NetworkNamespaces::run_in(net.ns_a(), [&] { v.ring = ring_or_skip(c, v.why); });
  if (!v.ring) return v;
  NetworkNamespaces::run_in(net.ns_b(), [&] {
    std::vector<Endpoint> dst;
    for (const auto port : ports) dst.push_back({VethPair::kAddrA, port});
    v.tx.emplace(dst);
  });
  return v;
}

TEST(RingSource, VethNamespacesFragmentsReassembled) {
  VethPair net;
  if (!net.error().empty()) GTEST_SKIP() << net.error();
  constexpr std::uint16_t kPort = 7502, kOtherPort = 7503;
  RingSourceConfig c;
  c.port = kPort;
  in_addr b{};
  ::inet_pton(AF_INET, VethPair::kAddrB, &b);
  c.sensor_host = ntohl(b.s_addr);
  auto [ring, tx, why] = ring_across(net, c, {kPort, kOtherPort});
  if (!ring) GTEST_SKIP() << why;
  std::optional<UdpSource> taker;
  NetworkNamespaces::run_in(net.ns_a(), [&] { taker.emplace(UdpSourceConfig{{"0.0.0.0", kPort}, 1 << 20, 64, false}); });
  const Nanos before = vehicle_now_ns();
  std::vector<Bytes> sent;
  std::size_t frames = 0, other_fragmented = 0, fragmented = 0;
  for (unsigned round = 0; round < 3; ++round) {
    for (std::size_t k = 0; k < kSizes.size(); ++k) {
      sent.push_back(ring_payload(kSizes[k], round * 100 + static_cast<unsigned>(k)));
      ASSERT_EQ(tx->send(sent.back(), 0).sent, 1u) << kSizes[k];
      frames += fragments_of(kSizes[k]);
      fragmented += fragments_of(kSizes[k]) > 1;
      // Another port: its unfragmented datagrams stop at the kernel filter, its fragments are
      // reassembled and then dropped as filtered.
      const std::size_t other = k % 2 == 0 ? 300 : 5000;
      ASSERT_EQ(tx->send(ring_payload(other, 7), 1).sent, 1u);
      if (fragments_of(other) > 1) {
        frames += fragments_of(other);
        ++other_fragmented;
      }
    }
    ::usleep(2000);  // the veth backlog stays short on a slow host
  }
  const auto got = receive_all(*ring, sent.size());
  const Nanos after = vehicle_now_ns();
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].bytes.size(), sent[i].size()) << "datagram " << i;
    EXPECT_TRUE(got[i].bytes == sent[i]) << "datagram " << i << " differs";
    EXPECT_GE(got[i].rx_ns, before);
    EXPECT_LE(got[i].rx_ns, after);
    EXPECT_EQ(got[i].src, 0x0ad50002u);  // 10.213.0.2
  }
  // The other port's last datagram may still sit in a block the kernel has not retired.
  (void)receive_all(*ring, 1, 3);
  ring->refresh_kernel_stats();
  const auto& st = ring->stats();
  EXPECT_EQ(st.packets, sent.size());
  EXPECT_EQ(st.ring_packets, frames) << "only the sensor's datagrams and UDP fragments enter the ring";
  EXPECT_EQ(st.ring_drops, 0u);
  EXPECT_EQ(st.reassembly.reassembled, fragmented + other_fragmented);
  EXPECT_EQ(st.reassembly.dropped_total(), 0u);
  EXPECT_EQ(st.filtered, other_fragmented);
  EXPECT_EQ(st.missing_timestamps, 0u);
  EXPECT_EQ(st.truncated, 0u);
}

// One ring for both of a sensor's ports across the veth pair: fragmented data datagrams to 7502
// and 48-byte IMU packets to 7503 come out in the order sent, each with its port and its own
// IPv4/UDP headers (a reassembled one's with a valid checksum and no fragment bits); a third port
// never enters the ring.
TEST(RingSource, VethNamespacesSecondPortThroughTheSameRing) {
  VethPair net;
  if (!net.error().empty()) GTEST_SKIP() << net.error();
  constexpr std::uint16_t kPort = 7502, kImuPort = 7503, kOtherPort = 7504;
  RingSourceConfig c;
  c.port = kPort;
  c.second_port = kImuPort;
  auto [ring, tx, why] = ring_across(net, c, {kPort, kImuPort, kOtherPort});
  if (!ring) GTEST_SKIP() << why;
  std::vector<std::pair<std::uint16_t, Bytes>> sent;
  for (unsigned k = 0; k < 30; ++k) {
    const bool imu = k % 3 != 0;
    sent.emplace_back(imu ? kImuPort : kPort, ring_payload(imu ? 48 : 6464, k));
    ASSERT_EQ(tx->send(sent.back().second, imu ? 1 : 0).sent, 1u);
    ASSERT_EQ(tx->send(ring_payload(48, 99), 2).sent, 1u);
  }
  const auto got = receive_all(*ring, sent.size());
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].dst_port, sent[i].first);
    EXPECT_TRUE(got[i].bytes == sent[i].second);
    const Bytes& h = got[i].headers;
    ASSERT_EQ(h.size(), 28u);
    EXPECT_EQ(std::to_integer<int>(h[0]), 0x45);
    EXPECT_EQ((std::to_integer<int>(h[6]) & 0x3f) | std::to_integer<int>(h[7]), 0) << "no fragment bits";
    EXPECT_EQ(std::to_integer<std::size_t>(h[2]) << 8 | std::to_integer<std::size_t>(h[3]), 28 + sent[i].second.size());
    EXPECT_EQ(ipv4_header_checksum(std::span(h).first(20)), 0) << "a valid checksum";
    EXPECT_EQ(std::to_integer<int>(h[16]), 10);  // destination 10.213.0.1, as sent
    EXPECT_EQ(std::to_integer<int>(h[19]), 1);
    EXPECT_EQ(std::to_integer<int>(h[22]) << 8 | std::to_integer<int>(h[23]), sent[i].first);
  }
  (void)receive_all(*ring, 1, 3);
  ring->refresh_kernel_stats();
  EXPECT_EQ(ring->stats().second_port_packets, 20u);
  EXPECT_EQ(ring->stats().reassembly.reassembled, 10u);
  EXPECT_EQ(ring->stats().filtered, 0u) << "the third port's datagrams stop at the kernel filter";
  EXPECT_EQ(ring->stats().ring_packets, 10u * 5 + 20u);
  EXPECT_EQ(ring->stats().ring_drops, 0u);
}

// The interface going down (a NIC unplugged, a link reset) is an error the caller sees once, not a
// hang or a busy loop; when it comes back the same socket receives again.
TEST(RingSource, InterfaceDownIsReportedAndRecovers) {
  VethPair net;
  if (!net.error().empty()) GTEST_SKIP() << net.error();
  constexpr std::uint16_t kPort = 2368;
  RingSourceConfig c;
  c.port = kPort;
  auto [ring, tx, why] = ring_across(net, c, {kPort});
  if (!ring) GTEST_SKIP() << why;
  const auto p = ring_payload(1206, 1);
  ASSERT_EQ(tx->send(p).sent, 1u);
  ASSERT_EQ(receive_all(*ring, 1).size(), 1u);
  ASSERT_EQ(std::system(("ip -n " + net.ns_a() + " link set " + net.if_a() + " down").c_str()), 0);
  SlotArena arena(4, 2048);
  int errors = 0, timeouts = 0;
  for (int k = 0; k < 5; ++k) {
    const auto r = ring->receive(arena.slots(), 50);
    if (r.status == RecvStatus::kError) {
      ++errors;
      EXPECT_EQ(r.error, ENETDOWN);
    }
    if (r.status == RecvStatus::kTimeout) ++timeouts;
  }
  EXPECT_EQ(errors, 1) << "reported once";
  EXPECT_EQ(timeouts, 4) << "then the receive waits again (no busy loop)";
  ASSERT_EQ(std::system(("ip -n " + net.ns_a() + " link set " + net.if_a() + " up").c_str()), 0);
  // The link needs a moment to come up (both veth ends up, carrier): resend until one arrives.
  std::size_t got = 0;
  for (int k = 0; k < 40 && got == 0; ++k) {
    tx->send(p);
    got = receive_all(*ring, 1, 1).size();
  }
  EXPECT_EQ(got, 1u) << "the same socket receives again after the interface came back";
  EXPECT_EQ(ring->stats().errors, 1u);
}

}  // namespace
}  // namespace sensor_rig::lidar
