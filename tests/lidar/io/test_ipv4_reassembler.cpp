// The packet-ring source's IPv4 reassembler on synthetic fragments: every order gives back the
// datagram byte for byte; duplicates are ignored; overlaps, missing fragments (timeout), too many
// datagrams in flight, oversize and malformed fragments are dropped and counted once, by reason.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "ipv4_packets.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/ipv4_reassembler.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

using test::Bytes;
using test::Ip;

std::uint64_t dropped(const Ipv4Reassembler& r, ReassemblyDrop d) {
  return r.counters().dropped[static_cast<std::size_t>(d)];
}

// The whole UDP payload of a completed datagram, through the same parser the ring source uses.
Bytes udp_payload(std::span<const std::byte> datagram) {
  const auto f = parse_udp_frame(228, datagram);
  EXPECT_EQ(f.status, FrameStatus::kOk) << to_string(f.status);
  return {f.payload.begin(), f.payload.end()};
}

struct Case {
  Ip ip;
  Bytes payload = test::payload_of(9000, 3);
  Bytes segment = test::udp_segment(7502, 7502, payload);
  std::vector<Bytes> frags = test::fragments(ip, segment, 1480);
};

// Pushes all fragments; expects exactly the last push to complete, returns the UDP payload.
Bytes push_all(Ipv4Reassembler& r, const std::vector<Bytes>& frags, Nanos t0 = 1000 * kMs) {
  Bytes out;
  for (std::size_t i = 0; i < frags.size(); ++i) {
    const auto res = r.push(frags[i], t0 + static_cast<Nanos>(i));
    if (i + 1 < frags.size()) {
      EXPECT_EQ(res.status, ReassemblyStatus::kIncomplete) << "fragment " << i;
    } else {
      EXPECT_EQ(res.status, ReassemblyStatus::kComplete);
      EXPECT_EQ(res.rx_ns, t0 + static_cast<Nanos>(i)) << "the stamp of the fragment that completed it";
      out = udp_payload(res.datagram);
    }
  }
  return out;
}

TEST(Ipv4Reassembler, WholeDatagramPassesThrough) {
  Ipv4Reassembler r;
  const Ip ip;
  const auto pkt = test::ipv4_packet(ip, 0, false, test::udp_segment(1, 2, test::payload_of(100, 1)));
  Bytes padded = pkt;
  padded.resize(pkt.size() + 6);  // Ethernet padding after the datagram is not part of it
  const auto res = r.push(padded, 5);
  ASSERT_EQ(res.status, ReassemblyStatus::kNotFragment);
  EXPECT_EQ(res.datagram.size(), pkt.size());
  EXPECT_EQ(r.counters().fragments, 0u);
}

TEST(Ipv4Reassembler, InOrderReverseAndShuffled) {
  Case c;
  ASSERT_EQ(c.frags.size(), 7u);  // 9008 B of UDP in 1480 B pieces
  Ipv4Reassembler r;
  // One datagram a second: an IPv4 id is not used again within the timeout (RFC 6864), and a copy
  // of a datagram just completed is a duplicate.
  EXPECT_EQ(push_all(r, c.frags, 1000 * kMs), c.payload);
  auto rev = c.frags;
  std::reverse(rev.begin(), rev.end());
  EXPECT_EQ(push_all(r, rev, 2000 * kMs), c.payload);
  std::mt19937 rng(7);
  for (int k = 0; k < 5; ++k) {
    auto shuffled = c.frags;
    std::shuffle(shuffled.begin(), shuffled.end(), rng);
    EXPECT_EQ(push_all(r, shuffled, (3 + k) * 1000 * kMs), c.payload);
  }
  EXPECT_EQ(r.counters().reassembled, 7u);
  EXPECT_EQ(r.counters().dropped_total(), 0u);
  EXPECT_EQ(r.in_flight(), 0u);
}

TEST(Ipv4Reassembler, InterleavedDatagramsKeyedBySrcDstIdProto) {
  Case a, b, d;
  b.ip.id = a.ip.id;  // same id, other source: another datagram
  b.ip.src = 0x0a000009;
  b.payload = test::payload_of(5000, 4);
  b.segment = test::udp_segment(7502, 7502, b.payload);
  b.frags = test::fragments(b.ip, b.segment, 1480);
  d.ip.proto = 253;  // same addresses and id, other protocol
  d.frags = test::fragments(d.ip, test::payload_of(3000, 5), 1480);
  Ipv4Reassembler r;
  std::vector<Bytes> completed;
  std::size_t n = std::max({a.frags.size(), b.frags.size(), d.frags.size()});
  for (std::size_t i = 0; i < n; ++i)
    for (auto* c : {&a, &b, &d})
      if (i < c->frags.size()) {
        const auto res = r.push(c->frags[i], 1);
        if (res.status == ReassemblyStatus::kComplete) completed.emplace_back(res.datagram.begin(), res.datagram.end());
      }
  ASSERT_EQ(completed.size(), 3u);
  ASSERT_EQ(d.frags.size(), 3u);
  EXPECT_EQ(std::to_integer<int>(completed[0][9]), 253);  // 3 fragments: done first
  EXPECT_EQ(Bytes(completed[0].begin() + 20, completed[0].end()), test::payload_of(3000, 5));
  EXPECT_EQ(udp_payload(completed[1]), b.payload);  // 4 fragments
  EXPECT_EQ(udp_payload(completed[2]), a.payload);  // 7 fragments
}

TEST(Ipv4Reassembler, HeaderOptionsOfTheFirstFragmentAreNotPayload) {
  Case c;
  c.ip.header_bytes = 24;
  c.frags = test::fragments(c.ip, c.segment, 1480);
  Ipv4Reassembler r;
  EXPECT_EQ(push_all(r, c.frags), c.payload);
}

TEST(Ipv4Reassembler, ExactDuplicateIsIgnored) {
  Case c;
  Ipv4Reassembler r;
  auto frags = c.frags;
  frags.insert(frags.begin() + 3, c.frags[1]);
  Bytes out;
  for (const auto& f : frags) {
    const auto res = r.push(f, 1);
    if (res.status == ReassemblyStatus::kComplete) out = udp_payload(res.datagram);
  }
  EXPECT_EQ(out, c.payload);
  EXPECT_EQ(r.counters().duplicates, 1u);
  EXPECT_EQ(r.counters().dropped_total(), 0u);
}

// Issue 26 item 7: a copy of a fragment that comes after its datagram completed is a duplicate,
// not a datagram of its own that later expires as a `timeout` (the old code counted it so).
TEST(Ipv4Reassembler, DuplicateAfterCompletionIsADuplicateNotATimeout) {
  Case c;
  Ipv4Reassembler r;
  ASSERT_EQ(push_all(r, c.frags, 1000 * kMs), c.payload);
  for (const std::size_t i : {std::size_t{0}, c.frags.size() / 2, c.frags.size() - 1})
    EXPECT_NE(r.push(c.frags[i], 1010 * kMs).status, ReassemblyStatus::kComplete) << "fragment " << i;
  EXPECT_EQ(r.in_flight(), 0u) << "no datagram opened for the copies";
  r.expire(2000 * kMs);
  EXPECT_EQ(r.counters().duplicates, 3u);
  EXPECT_EQ(dropped(r, ReassemblyDrop::kTimeout), 0u);
  EXPECT_EQ(r.counters().dropped_total(), 0u);
  EXPECT_EQ(r.counters().reassembled, 1u);
  // After the timeout the id is free again: the same fragments are a new datagram.
  EXPECT_EQ(push_all(r, c.frags, 3000 * kMs), c.payload);
  EXPECT_EQ(r.counters().reassembled, 2u);
}

// The timeout runs on the age clock (monotonic), not on the receive stamps (realtime): a host
// clock step between two fragments neither gives the datagram up nor changes its stamp.
TEST(Ipv4Reassembler, TimeoutRunsOnTheAgeClockNotTheStamps) {
  Case c;
  Ipv4ReassemblerConfig cfg;
  cfg.timeout_ns = 50 * kMs;
  Ipv4Reassembler r(cfg);
  const Nanos rx0 = 5'000'000 * kMs, age0 = 100 * kMs;
  ASSERT_EQ(r.push(c.frags[0], rx0, age0).status, ReassemblyStatus::kIncomplete);
  const Nanos step = 1'000 * kMs;  // CLOCK_REALTIME stepped forward 1 s; 1 ms passed
  EXPECT_EQ(r.expire(age0 + 1 * kMs), 0u);
  Bytes out;
  Nanos stamp = 0;
  for (std::size_t i = 1; i < c.frags.size(); ++i) {
    const auto res = r.push(c.frags[i], rx0 + step + static_cast<Nanos>(i), age0 + 2 * kMs);
    if (res.status == ReassemblyStatus::kComplete) {
      out = udp_payload(res.datagram);
      stamp = res.rx_ns;
    }
  }
  EXPECT_EQ(out, c.payload);
  EXPECT_EQ(stamp, rx0 + step + static_cast<Nanos>(c.frags.size() - 1)) << "stamped by the kernel's clock";
  EXPECT_EQ(r.counters().dropped_total(), 0u);
  // An incomplete one expires timeout_ns after its first fragment on the age clock, whatever the stamps say.
  ASSERT_EQ(r.push(c.frags[0], rx0 - step, age0 + 100 * kMs).status, ReassemblyStatus::kIncomplete);
  EXPECT_EQ(r.expire(age0 + 149 * kMs), 0u);
  EXPECT_EQ(r.expire(age0 + 150 * kMs), 1u);
}

TEST(Ipv4Reassembler, OverlapDropsTheDatagramOnce) {
  Case c;
  Ipv4Reassembler r;
  ASSERT_EQ(r.push(c.frags[0], 1).status, ReassemblyStatus::kIncomplete);
  // 8 bytes into the first fragment's data: overlaps, is not a duplicate.
  const auto overlap = test::ipv4_packet(c.ip, 1480 - 8, true, test::payload_of(16, 9));
  EXPECT_EQ(r.push(overlap, 2).status, ReassemblyStatus::kDropped);
  EXPECT_EQ(dropped(r, ReassemblyDrop::kOverlap), 1u);
  for (std::size_t i = 1; i < c.frags.size(); ++i)
    EXPECT_EQ(r.push(c.frags[i], 3).status, ReassemblyStatus::kDropped) << "late fragments are swallowed";
  r.expire(1000 * kMs);
  EXPECT_EQ(r.counters().dropped_total(), 1u) << "counted once, not again as a timeout";
  EXPECT_EQ(r.counters().reassembled, 0u);
  EXPECT_EQ(push_all(r, c.frags, 2000 * kMs), c.payload) << "the id can be used again after the timeout";
}

TEST(Ipv4Reassembler, MissingFragmentTimesOut) {
  Case c;
  Ipv4ReassemblerConfig cfg;
  cfg.timeout_ns = 50 * kMs;
  Ipv4Reassembler r(cfg);
  for (std::size_t i = 0; i + 1 < c.frags.size(); ++i) r.push(c.frags[i], 10 * kMs);
  EXPECT_EQ(r.in_flight(), 1u);
  EXPECT_EQ(r.expire(59 * kMs), 0u);
  EXPECT_EQ(r.expire(60 * kMs), 1u);
  EXPECT_EQ(dropped(r, ReassemblyDrop::kTimeout), 1u);
  EXPECT_EQ(r.in_flight(), 0u);
  EXPECT_EQ(r.push(c.frags.back(), 61 * kMs).status, ReassemblyStatus::kIncomplete) << "a new datagram";
}

TEST(Ipv4Reassembler, TooManyInFlightGivesUpTheOldest) {
  Ipv4ReassemblerConfig cfg;
  cfg.max_in_flight = 3;
  Ipv4Reassembler r(cfg);
  std::vector<Case> cs(4);
  for (std::size_t k = 0; k < cs.size(); ++k) {
    cs[k].ip.id = static_cast<std::uint16_t>(100 + k);
    cs[k].frags = test::fragments(cs[k].ip, cs[k].segment, 1480);
    EXPECT_EQ(r.push(cs[k].frags[0], static_cast<Nanos>(k + 1)).status, ReassemblyStatus::kIncomplete);
  }
  EXPECT_EQ(dropped(r, ReassemblyDrop::kTooMany), 1u);
  EXPECT_EQ(r.in_flight(), 3u);
  // The oldest (id 100) was given up: its remaining fragments open a new, incomplete datagram.
  Bytes out;
  for (std::size_t i = 1; i < cs[3].frags.size(); ++i) {
    const auto res = r.push(cs[3].frags[i], 10);
    if (res.status == ReassemblyStatus::kComplete) out = udp_payload(res.datagram);
  }
  EXPECT_EQ(out, cs[3].payload);
}

TEST(Ipv4Reassembler, OversizeDatagramIsDropped) {
  Ipv4ReassemblerConfig cfg;
  cfg.max_datagram_bytes = 4000;
  Ipv4Reassembler r(cfg);
  Case c;  // 9 kB
  std::size_t dropped_pushes = 0;
  for (const auto& f : c.frags)
    if (r.push(f, 1).status == ReassemblyStatus::kDropped) ++dropped_pushes;
  EXPECT_GE(dropped_pushes, 1u);
  EXPECT_EQ(dropped(r, ReassemblyDrop::kOversize), 1u);
  EXPECT_EQ(r.counters().reassembled, 0u);
  r.expire(1000 * kMs);
  EXPECT_EQ(r.counters().dropped_total(), 1u);

  Ipv4ReassemblerConfig few;
  few.max_fragments = 4;  // 7 fragments: cut in too many pieces
  Ipv4Reassembler r2(few);
  for (const auto& f : c.frags) r2.push(f, 1);
  EXPECT_EQ(dropped(r2, ReassemblyDrop::kOversize), 1u);
}

TEST(Ipv4Reassembler, MalformedFragmentsAreCounted) {
  Ipv4Reassembler r;
  const Ip ip;
  EXPECT_EQ(r.push(Bytes(12), 1).status, ReassemblyStatus::kDropped);  // shorter than a header
  auto bad_version = test::ipv4_packet(ip, 0, true, test::payload_of(16, 1));
  bad_version[0] = std::byte{0x65};
  EXPECT_EQ(r.push(bad_version, 1).status, ReassemblyStatus::kDropped);
  auto too_long = test::ipv4_packet(ip, 0, true, test::payload_of(16, 1));
  test::put16(too_long, 2, 400);  // total length past the captured bytes
  EXPECT_EQ(r.push(too_long, 1).status, ReassemblyStatus::kDropped);
  Ip odd = ip;
  odd.id = 7;
  EXPECT_EQ(r.push(test::ipv4_packet(odd, 0, true, test::payload_of(13, 1)), 1).status, ReassemblyStatus::kDropped)
      << "a non-last fragment's length must be a multiple of 8";
  Ip two_ends = ip;
  two_ends.id = 8;
  EXPECT_EQ(r.push(test::ipv4_packet(two_ends, 16, false, test::payload_of(8, 1)), 1).status,
            ReassemblyStatus::kIncomplete);
  EXPECT_EQ(r.push(test::ipv4_packet(two_ends, 32, false, test::payload_of(8, 1)), 1).status,
            ReassemblyStatus::kDropped) << "two different last fragments";
  Ip past_end = ip;
  past_end.id = 9;
  r.push(test::ipv4_packet(past_end, 8, false, test::payload_of(8, 1)), 1);  // ends at 16
  EXPECT_EQ(r.push(test::ipv4_packet(past_end, 24, true, test::payload_of(8, 1)), 1).status,
            ReassemblyStatus::kDropped) << "data after the last fragment's end";
  EXPECT_EQ(dropped(r, ReassemblyDrop::kMalformed), 6u);
  EXPECT_EQ(r.counters().reassembled, 0u);
}

TEST(Ipv4Reassembler, ConfigIsChecked) {
  Ipv4ReassemblerConfig c;
  c.max_in_flight = 0;
  EXPECT_THROW(Ipv4Reassembler{c}, std::invalid_argument);
  c = {};
  c.max_datagram_bytes = 70000;
  EXPECT_THROW(Ipv4Reassembler{c}, std::invalid_argument);
  c = {};
  c.timeout_ns = 0;
  EXPECT_THROW(Ipv4Reassembler{c}, std::invalid_argument);
}

}  // namespace
}  // namespace sensor_rig::lidar
