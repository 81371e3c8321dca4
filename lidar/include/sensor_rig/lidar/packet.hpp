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
  // The receive time on CLOCK_MONOTONIC (0: unknown, e.g. a capture): the gaps between packets
  // that a host CLOCK_REALTIME step does not move (packet_time.hpp RxTimes).
  Nanos rx_mono_ns = 0;
};

// A kernel receive stamp (CLOCK_REALTIME) on CLOCK_MONOTONIC, by the clocks' pair `read` when the
// packet was read: 0 when that cannot be right, the stamp later than the read (the host's clock
// stepped back in between) or more than 2 s before it (stepped forward; a socket buffer holds far
// less of a sensor's stream).
[[nodiscard]] constexpr Nanos monotonic_receive_ns(Nanos rx_ns, Nanos read_vehicle_minus_monotonic, Nanos read_monotonic_ns) noexcept {
  if (rx_ns <= 0) return 0;
  const Nanos mono = rx_ns - read_vehicle_minus_monotonic;
  return mono <= read_monotonic_ns + 1'000'000 && mono >= read_monotonic_ns - 2'000'000'000 ? mono : 0;
}

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
