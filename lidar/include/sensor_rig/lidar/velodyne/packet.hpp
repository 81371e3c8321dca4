#pragma once
// Velodyne data and position packet layouts (VLP-16, VLP-32C, HDL-32E user manuals).
// Layout as types with sizes asserted; multi-byte fields are little-endian on the wire and are
// read through the accessors below (memcpy + explicit byte order), never by casting the buffer.
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>

#include "sensor_rig/lidar/byte_order.hpp"

namespace sensor_rig::lidar::velodyne {

inline constexpr std::size_t kDataPacketSize = 1206;      // UDP payload
inline constexpr std::size_t kPositionPacketSize = 512;   // UDP payload
inline constexpr std::size_t kBlocksPerPacket = 12;
inline constexpr std::size_t kChannelsPerBlock = 32;
inline constexpr std::uint16_t kBlockFlagUpper = 0xEEFF;  // bytes FF EE read little-endian
inline constexpr std::uint16_t kDataPort = 2368;
inline constexpr std::uint16_t kPositionPort = 8308;

struct RawChannel {
  std::uint8_t distance[2];  // little-endian, units of the model's distance resolution
  std::uint8_t intensity;
};
static_assert(sizeof(RawChannel) == 3);

struct RawBlock {
  std::uint8_t flag[2];     // FF EE
  std::uint8_t azimuth[2];  // little-endian, hundredths of a degree, 0..35999
  RawChannel channels[kChannelsPerBlock];
};
static_assert(sizeof(RawBlock) == 100);

struct RawDataPacket {
  RawBlock blocks[kBlocksPerPacket];
  std::uint8_t timestamp[4];  // little-endian, µs since the top of the hour (sensor clock)
  std::uint8_t return_mode;   // ReturnMode
  std::uint8_t product_id;    // ProductId
};
static_assert(sizeof(RawDataPacket) == kDataPacketSize);

enum class ReturnMode : std::uint8_t { kStrongest = 0x37, kLast = 0x38, kDual = 0x39 };
enum class ProductId : std::uint8_t {
  kHDL32E = 0x21,
  kVLP16 = 0x22,
  kPuckLite = 0x23,
  kPuckHiRes = 0x24,
  kVLP32C = 0x28,
  kVelarray = 0x31,
  kVLS128 = 0xA1,
};

using lidar::le16;  // sensor_rig/lidar/byte_order.hpp
using lidar::le32;
using lidar::put_le16;
using lidar::put_le32;

// Bounds-checked view: only a buffer of exactly kDataPacketSize bytes yields a packet.
inline std::optional<RawDataPacket> read_data_packet(std::span<const std::byte> bytes) noexcept {
  if (bytes.size() != kDataPacketSize) return std::nullopt;
  RawDataPacket p;
  std::memcpy(&p, bytes.data(), sizeof p);
  return p;
}

}  // namespace sensor_rig::lidar::velodyne
