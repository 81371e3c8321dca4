#pragma once
// Synthetic IPv4/UDP packets and their fragments, for the reassembler and BPF filter tests.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace sensor_rig::lidar::test {

using Bytes = std::vector<std::byte>;

inline void put16(Bytes& b, std::size_t at, std::uint16_t v) {
  b[at] = static_cast<std::byte>(v >> 8);
  b[at + 1] = static_cast<std::byte>(v & 0xff);
}
inline void put32(Bytes& b, std::size_t at, std::uint32_t v) {
  put16(b, at, static_cast<std::uint16_t>(v >> 16));
  put16(b, at + 2, static_cast<std::uint16_t>(v & 0xffff));
}

inline Bytes payload_of(std::size_t n, unsigned seed) {
  Bytes p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::byte>((i * 31 + seed * 7 + (i >> 8)) & 0xff);
  return p;
}

struct Ip {
  std::uint32_t src = 0x0a000001;  // 10.0.0.1
  std::uint32_t dst = 0x0a000002;
  std::uint16_t id = 1;
  std::uint8_t proto = 17;
  std::size_t header_bytes = 20;  // > 20: options (zero bytes)
};

// An IPv4 packet: header (fragment fields as given) + `data`.
inline Bytes ipv4_packet(const Ip& ip, std::uint32_t offset_bytes, bool more, const Bytes& data) {
  Bytes b(ip.header_bytes + data.size());
  b[0] = static_cast<std::byte>(0x40 | (ip.header_bytes / 4));
  put16(b, 2, static_cast<std::uint16_t>(b.size()));
  put16(b, 4, ip.id);
  put16(b, 6, static_cast<std::uint16_t>((more ? 0x2000 : 0) | (offset_bytes / 8)));
  b[8] = std::byte{64};
  b[9] = static_cast<std::byte>(ip.proto);
  put32(b, 12, ip.src);
  put32(b, 16, ip.dst);
  for (std::size_t i = 0; i < data.size(); ++i) b[ip.header_bytes + i] = data[i];
  return b;
}

// UDP header + payload (checksum 0: "none", as IPv4 allows).
inline Bytes udp_segment(std::uint16_t sport, std::uint16_t dport, const Bytes& payload) {
  Bytes b(8 + payload.size());
  put16(b, 0, sport);
  put16(b, 2, dport);
  put16(b, 4, static_cast<std::uint16_t>(b.size()));
  for (std::size_t i = 0; i < payload.size(); ++i) b[8 + i] = payload[i];
  return b;
}

// The IP payload cut into fragments of at most `chunk` bytes (a multiple of 8), in order.
inline std::vector<Bytes> fragments(const Ip& ip, const Bytes& ip_payload, std::size_t chunk) {
  std::vector<Bytes> out;
  for (std::size_t off = 0; off < ip_payload.size(); off += chunk) {
    const std::size_t n = std::min(chunk, ip_payload.size() - off);
    Bytes part(ip_payload.begin() + static_cast<std::ptrdiff_t>(off),
               ip_payload.begin() + static_cast<std::ptrdiff_t>(off + n));
    out.push_back(ipv4_packet(ip, static_cast<std::uint32_t>(off), off + n < ip_payload.size(), part));
  }
  return out;
}

}  // namespace sensor_rig::lidar::test
