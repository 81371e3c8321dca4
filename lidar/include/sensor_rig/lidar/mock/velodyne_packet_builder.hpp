#pragma once
// Crafts Velodyne data packets with chosen azimuths, distances and intensities (test-only).
#include <array>
#include <cstring>
#include <span>

#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::velodyne_builder {

class PacketBuilder {
 public:
  explicit PacketBuilder(velodyne::ProductId pid = velodyne::ProductId::kVLP16,
                         velodyne::ReturnMode mode = velodyne::ReturnMode::kStrongest) {
    std::memset(&p_, 0, sizeof p_);
    for (auto& b : p_.blocks) velodyne::put_le16(b.flag, velodyne::kBlockFlagUpper);
    p_.return_mode = static_cast<std::uint8_t>(mode);
    p_.product_id = static_cast<std::uint8_t>(pid);
  }
  // Block b at azimuth a (hundredths of a degree).
  PacketBuilder& azimuth(std::size_t b, int a) {
    velodyne::put_le16(p_.blocks[b].azimuth, static_cast<std::uint16_t>(a));
    return *this;
  }
  // Azimuths a0, a0+step, ... for the 12 blocks (wrapping at 36000); dual: pairs share one.
  PacketBuilder& azimuths(int a0, int step, bool dual = false) {
    for (std::size_t b = 0; b < velodyne::kBlocksPerPacket; ++b) {
      const int k = dual ? static_cast<int>(b / 2) : static_cast<int>(b);
      azimuth(b, (a0 + k * step) % 36000);
    }
    return *this;
  }
  PacketBuilder& ret(std::size_t b, std::size_t c, std::uint16_t raw, std::uint8_t intensity) {
    velodyne::put_le16(p_.blocks[b].channels[c].distance, raw);
    p_.blocks[b].channels[c].intensity = intensity;
    return *this;
  }
  PacketBuilder& all(std::uint16_t raw, std::uint8_t intensity) {
    for (std::size_t b = 0; b < velodyne::kBlocksPerPacket; ++b)
      for (std::size_t c = 0; c < velodyne::kChannelsPerBlock; ++c) ret(b, c, raw, intensity);
    return *this;
  }
  PacketBuilder& timestamp(std::uint32_t us) {
    velodyne::put_le32(p_.timestamp, us);
    return *this;
  }
  velodyne::RawDataPacket& raw() { return p_; }
  std::array<std::byte, velodyne::kDataPacketSize> bytes() const {
    std::array<std::byte, velodyne::kDataPacketSize> out{};
    std::memcpy(out.data(), &p_, sizeof p_);
    return out;
  }

 private:
  velodyne::RawDataPacket p_{};
};

}  // namespace sensor_rig::lidar::velodyne_builder
