#pragma once
// Hesai Pandar40P and PandarXT32 data packet layouts (user manuals; nebula's hesai_packet.hpp).
// Layouts as types with sizes asserted. Every field is a byte array: multi-byte fields are
// little-endian on the wire and are read through the accessors below (explicit byte order),
// never by casting the buffer. Offsets used by the decoder come from these types (offsetof).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "sensor_rig/lidar/byte_order.hpp"

namespace sensor_rig::lidar::hesai {

inline constexpr std::uint16_t kDataPort = 2368;
inline constexpr std::uint16_t kGpsPort = 10110;          // GPS/PPS status packets (not point data)
inline constexpr std::size_t kGpsPacketSize = 512;
inline constexpr int kAzimuthCount = 36000;               // azimuth unit: 0.01°

// ---- Pandar40P: 10 blocks x 40 channels, no header, 22-byte tail (+ optional 4-byte UDP sequence).
struct Unit3 {
  std::uint8_t distance[2];  // units of 4 mm; 0 = no return
  std::uint8_t reflectivity;
};
static_assert(sizeof(Unit3) == 3);

struct Block40P {
  std::uint8_t sob[2];      // start of block: FF EE
  std::uint8_t azimuth[2];  // 0.01°, 0..35999, clockwise seen from above, 0 = sensor front
  Unit3 units[40];          // channel 1..40 (channel 1 = highest elevation)
};
static_assert(sizeof(Block40P) == 124);

struct Tail40P {
  std::uint8_t reserved1[5];
  std::uint8_t high_temperature_flag;
  std::uint8_t reserved2[2];
  std::uint8_t motor_speed[2];  // rpm
  std::uint8_t timestamp[4];    // µs within the UTC second below
  std::uint8_t return_mode;     // ReturnMode
  std::uint8_t factory_info;
  std::uint8_t utc[6];          // year - 2000, month, day, hour, minute, second
};
static_assert(sizeof(Tail40P) == 22);

struct Packet40P {
  Block40P blocks[10];
  Tail40P tail;
};
static_assert(sizeof(Packet40P) == 1262);
inline constexpr std::size_t k40PPacketSize = sizeof(Packet40P);
inline constexpr std::size_t k40PPacketSizeWithSequence = sizeof(Packet40P) + 4;

// ---- PandarXT32 (protocol 6.1): 12-byte header, 8 blocks x 32 channels, 24-byte tail, sequence.
struct HeaderXT {
  std::uint8_t sop[2];  // start of packet: EE FF
  std::uint8_t protocol_major;
  std::uint8_t protocol_minor;
  std::uint8_t reserved1[2];
  std::uint8_t laser_num;   // 32
  std::uint8_t block_num;   // 8
  std::uint8_t reserved2;
  std::uint8_t dis_unit;    // distance unit in mm (4)
  std::uint8_t return_num;  // 1 or 2
  std::uint8_t flags;
};
static_assert(sizeof(HeaderXT) == 12);

struct Unit4 {
  std::uint8_t distance[2];  // units of HeaderXT::dis_unit mm
  std::uint8_t reflectivity;
  std::uint8_t reserved;
};
static_assert(sizeof(Unit4) == 4);

struct BlockXT32 {
  std::uint8_t azimuth[2];  // 0.01°
  Unit4 units[32];          // channel 1..32 (channel 1 = highest elevation)
};
static_assert(sizeof(BlockXT32) == 130);

struct TailXT32 {
  std::uint8_t reserved1[10];
  std::uint8_t return_mode;     // ReturnMode
  std::uint8_t motor_speed[2];  // rpm
  std::uint8_t utc[6];          // year - 1900, month, day, hour, minute, second
  std::uint8_t timestamp[4];    // µs within the UTC second
  std::uint8_t factory_info;
};
static_assert(sizeof(TailXT32) == 24);

struct PacketXT32 {
  HeaderXT header;
  BlockXT32 blocks[8];
  TailXT32 tail;
  std::uint8_t udp_sequence[4];
};
static_assert(sizeof(PacketXT32) == 1080);
inline constexpr std::size_t kXT32PacketSize = sizeof(PacketXT32);

// Tail return mode byte. Dual modes send each azimuth as two consecutive blocks (one per echo).
enum class ReturnMode : std::uint8_t {
  kFirst = 0x33,
  kSecond = 0x34,
  kStrongest = 0x37,
  kLast = 0x38,
  kLastStrongest = 0x39,  // dual: block 2n = last, 2n+1 = strongest (second strongest if last is)
  kFirstSecond = 0x3A,
  kFirstLast = 0x3B,      // dual (XT32 sends the last echo first)
  kFirstStrongest = 0x3C,
};
// Echoes per azimuth for a return mode byte; 0 for an unknown byte.
constexpr int return_count(std::uint8_t mode) noexcept {
  switch (static_cast<ReturnMode>(mode)) {
    case ReturnMode::kFirst:
    case ReturnMode::kSecond:
    case ReturnMode::kStrongest:
    case ReturnMode::kLast:
      return 1;
    case ReturnMode::kLastStrongest:
    case ReturnMode::kFirstSecond:
    case ReturnMode::kFirstLast:
    case ReturnMode::kFirstStrongest:
      return 2;
  }
  return 0;
}

using lidar::le16;  // sensor_rig/lidar/byte_order.hpp
using lidar::le32;
using lidar::put_le16;
using lidar::put_le32;

// Seconds since the Unix epoch of a tail's date/time (UTC, no time zone involved); nullopt when a
// field is out of range (a sensor without time sync may send zeros).
std::optional<std::int64_t> utc_seconds(std::span<const std::uint8_t, 6> utc, int year_offset) noexcept;

}  // namespace sensor_rig::lidar::hesai
