#pragma once
// Link-layer frame -> UDP payload, for captured frames (pcap) or raw sockets. Pure parsing:
// Ethernet (with 802.1Q tags), Linux cooked v1/v2, raw IPv4 and BSD loopback; IPv4 only.
// Fragments are reported, not reassembled (LIDAR payloads fit one frame).
#include <cstddef>
#include <cstdint>
#include <span>

namespace sensor_rig::lidar {

enum class FrameStatus : std::uint8_t {
  kOk = 0,
  kNotIpv4,      // ARP, IPv6, ...
  kNotUdp,       // TCP, ICMP, ...
  kFragment,     // IPv4 fragment (more-fragments flag or non-zero offset)
  kTruncated,    // captured bytes end before the headers/payload do
  kBadHeader,    // inconsistent IPv4/UDP header
  kUnsupportedLink,
};
const char* to_string(FrameStatus s) noexcept;

struct UdpFrame {
  FrameStatus status = FrameStatus::kBadHeader;
  std::span<const std::byte> payload;  // valid when status == kOk
  std::uint32_t src_ip = 0;            // host byte order
  std::uint32_t dst_ip = 0;
  std::uint16_t src_port = 0;
  std::uint16_t dst_port = 0;
};

// `linktype` is the pcap DLT_/LINKTYPE_ value (1 Ethernet, 113 Linux SLL, 276 SLL2,
// 12/101/228 raw IPv4, 0 BSD loopback).
UdpFrame parse_udp_frame(int linktype, std::span<const std::byte> frame) noexcept;
bool linktype_supported(int linktype) noexcept;

// The IPv4 header checksum of `header` (its whole length, options included; the checksum field
// must hold 0 when computing the value to store there).
std::uint16_t ipv4_header_checksum(std::span<const std::byte> header) noexcept;

}  // namespace sensor_rig::lidar
