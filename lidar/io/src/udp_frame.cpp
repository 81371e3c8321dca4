#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

inline std::uint16_t be16(std::span<const std::byte> b, std::size_t o) noexcept {
  return static_cast<std::uint16_t>((std::to_integer<unsigned>(b[o]) << 8) | std::to_integer<unsigned>(b[o + 1]));
}
inline std::uint32_t be32(std::span<const std::byte> b, std::size_t o) noexcept {
  return (static_cast<std::uint32_t>(be16(b, o)) << 16) | be16(b, o + 2);
}

constexpr std::uint16_t kEtherIpv4 = 0x0800;
constexpr std::uint16_t kEtherVlan = 0x8100;
constexpr std::uint16_t kEtherQinQ = 0x88A8;

UdpFrame parse_ipv4(std::span<const std::byte> ip) noexcept {
  UdpFrame f;
  if (ip.size() < 20) return f.status = FrameStatus::kTruncated, f;
  const unsigned vihl = std::to_integer<unsigned>(ip[0]);
  if ((vihl >> 4) != 4) return f.status = FrameStatus::kNotIpv4, f;
  const std::size_t ihl = (vihl & 0x0F) * 4U;
  const std::size_t total = be16(ip, 2);
  if (ihl < 20 || total < ihl) return f.status = FrameStatus::kBadHeader, f;
  if (ip.size() < ihl) return f.status = FrameStatus::kTruncated, f;
  const std::uint16_t frag = be16(ip, 6);
  if ((frag & 0x2000) != 0 || (frag & 0x1FFF) != 0) return f.status = FrameStatus::kFragment, f;
  if (std::to_integer<unsigned>(ip[9]) != 17) return f.status = FrameStatus::kNotUdp, f;
  f.src_ip = be32(ip, 12);
  f.dst_ip = be32(ip, 16);
  if (total < ihl + 8) return f.status = FrameStatus::kBadHeader, f;
  if (ip.size() < ihl + 8) return f.status = FrameStatus::kTruncated, f;
  const auto udp = ip.subspan(ihl);
  f.src_port = be16(udp, 0);
  f.dst_port = be16(udp, 2);
  const std::size_t udp_len = be16(udp, 4);
  if (udp_len < 8 || ihl + udp_len > total) return f.status = FrameStatus::kBadHeader, f;
  // Ethernet padding may follow the IP datagram; the UDP length says where the payload ends.
  if (udp.size() < udp_len) return f.status = FrameStatus::kTruncated, f;
  f.payload = udp.subspan(8, udp_len - 8);
  f.status = FrameStatus::kOk;
  return f;
}

UdpFrame by_ethertype(std::uint16_t type, std::span<const std::byte> rest) noexcept {
  if (type != kEtherIpv4) {
    UdpFrame f;
    f.status = FrameStatus::kNotIpv4;
    return f;
  }
  return parse_ipv4(rest);
}

}  // namespace

const char* to_string(FrameStatus s) noexcept {
  switch (s) {
    case FrameStatus::kOk: return "ok";
    case FrameStatus::kNotIpv4: return "not_ipv4";
    case FrameStatus::kNotUdp: return "not_udp";
    case FrameStatus::kFragment: return "fragment";
    case FrameStatus::kTruncated: return "truncated";
    case FrameStatus::kBadHeader: return "bad_header";
    case FrameStatus::kUnsupportedLink: return "unsupported_link";
  }
  return "unknown";
}

bool linktype_supported(int linktype) noexcept {
  return linktype == 0 || linktype == 1 || linktype == 12 || linktype == 101 || linktype == 113 || linktype == 228 ||
         linktype == 276;
}

UdpFrame parse_udp_frame(int linktype, std::span<const std::byte> frame) noexcept {
  UdpFrame truncated;
  truncated.status = FrameStatus::kTruncated;
  switch (linktype) {
    case 1: {  // Ethernet II, optionally VLAN-tagged
      std::size_t off = 12;
      if (frame.size() < off + 2) return truncated;
      std::uint16_t type = be16(frame, off);
      for (int tags = 0; (type == kEtherVlan || type == kEtherQinQ) && tags < 2; ++tags) {
        off += 4;
        if (frame.size() < off + 2) return truncated;
        type = be16(frame, off);
      }
      return by_ethertype(type, frame.subspan(off + 2));
    }
    case 113:  // Linux cooked v1: 16-byte header, protocol at 14
      if (frame.size() < 16) return truncated;
      return by_ethertype(be16(frame, 14), frame.subspan(16));
    case 276:  // Linux cooked v2: 20-byte header, protocol at 0
      if (frame.size() < 20) return truncated;
      return by_ethertype(be16(frame, 0), frame.subspan(20));
    case 12:  // DLT_RAW as libpcap reports LINKTYPE_RAW
    case 101:
    case 228:
      return parse_ipv4(frame);
    case 0: {  // BSD loopback: 4-byte address family in host order (2 = AF_INET)
      if (frame.size() < 4) return truncated;
      const auto b0 = std::to_integer<unsigned>(frame[0]);
      const auto b3 = std::to_integer<unsigned>(frame[3]);
      if (b0 != 2 && b3 != 2) {
        UdpFrame f;
        f.status = FrameStatus::kNotIpv4;
        return f;
      }
      return parse_ipv4(frame.subspan(4));
    }
    default: {
      UdpFrame f;
      f.status = FrameStatus::kUnsupportedLink;
      return f;
    }
  }
}

std::uint16_t ipv4_header_checksum(std::span<const std::byte> header) noexcept {
  std::uint32_t sum = 0;
  for (std::size_t i = 0; i + 1 < header.size(); i += 2) sum += be16(header, i);
  while ((sum >> 16) != 0) sum = (sum & 0xFFFF) + (sum >> 16);
  return static_cast<std::uint16_t>(~sum & 0xFFFF);
}

}  // namespace sensor_rig::lidar
