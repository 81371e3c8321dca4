#pragma once
// A received or read packet as decoders see it: bytes plus the times known about it.
#include <cstddef>
#include <cstdint>
#include <span>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar {

struct PacketView {
  std::span<const std::byte> data;  // UDP payload
  Nanos rx_ns = 0;                  // kernel receive time (SO_TIMESTAMPNS) or pcap record time
  std::uint16_t dst_port = 0;       // UDP destination port (data vs position packets)
};

// Why a packet was not used. Hot paths return this; they never throw.
enum class PacketStatus : std::uint8_t {
  kOk = 0,
  kWrongSize,
  kBadBlockFlag,
  kWrongModel,     // product id / return mode byte does not match the configured model
  kBadAzimuth,
  kNotData,        // e.g. a position packet on the data port
  kTimeBackwards,  // sensor time jumped back beyond tolerance
  kOutOfOrder,     // steps back (a duplicate or a late, reordered packet): not decoded again
  kBadTime,        // one packet's time jumps while its azimuth / ids continue its neighbours': corrupt
};
inline constexpr std::size_t kPacketStatusCount = 9;  // PacketStatus values

const char* to_string(PacketStatus s) noexcept;

}  // namespace sensor_rig::lidar
