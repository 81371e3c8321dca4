// libFuzzer harness for the packet-ring source's pure parts (no sockets): the IPv4 reassembler and
// the sensor BPF filter run in userspace. Input: records [len_hi len_lo dt bytes...]; each record is
// one captured IPv4 packet at time += dt ms, pushed through the filter and the reassembler (small
// limits, so eviction, oversize and timeouts happen); `expire` every record.
// Invariants: no crash; the filter returns 0 or kFilterAcceptBytes; a completed datagram is a
// 20-byte header with version 4 / IHL 5, its total length = its size <= max_datagram_bytes, no
// fragment bits; open datagrams never exceed max_in_flight; completed + dropped never exceed the
// fragments pushed plus the packets refused as malformed.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "sensor_rig/lidar/ipv4_reassembler.hpp"
#include "sensor_rig/lidar/packet_filter.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"

namespace lidar = sensor_rig::lidar;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  lidar::Ipv4ReassemblerConfig cfg;
  cfg.max_in_flight = 4;
  cfg.max_datagram_bytes = 4000;
  cfg.max_fragments = 8;
  cfg.timeout_ns = 50'000'000;
  lidar::Ipv4Reassembler r(cfg);
  static const auto kFilter = lidar::build_sensor_filter({7502, 0x0a000001});
  sensor_rig::Nanos now = 1'000'000'000;
  std::uint64_t pushed = 0;
  std::size_t at = 0;
  while (at + 3 <= size) {
    const std::size_t len = (static_cast<std::size_t>(data[at]) << 8) | data[at + 1];
    now += static_cast<sensor_rig::Nanos>(data[at + 2]) * 1'000'000;
    at += 3;
    const std::size_t n = len < size - at ? len : size - at;
    const auto pkt = std::as_bytes(std::span(data + at, n));
    at += n;
    const auto keep = lidar::run_classic_bpf(kFilter, pkt);
    if (keep != 0 && keep != lidar::kFilterAcceptBytes) std::abort();
    r.expire(now);
    const auto res = r.push(pkt, now);
    ++pushed;
    if (res.status == lidar::ReassemblyStatus::kComplete) {
      const auto d = res.datagram;
      if (d.size() < 20 || d.size() > cfg.max_datagram_bytes) std::abort();
      if (std::to_integer<int>(d[0]) != 0x45) std::abort();
      if (((std::to_integer<std::size_t>(d[2]) << 8) | std::to_integer<std::size_t>(d[3])) != d.size()) std::abort();
      if ((std::to_integer<int>(d[6]) & 0x3f) != 0 || std::to_integer<int>(d[7]) != 0) std::abort();
      (void)lidar::parse_udp_frame(228, d);
    }
    if (r.in_flight() > cfg.max_in_flight) std::abort();
    const auto& c = r.counters();
    if (c.reassembled + c.dropped_total() > pushed) std::abort();
  }
  return 0;
}
