#pragma once
// Builds Hesai data packets (Pandar40P, PandarXT32) from the layout types, for tests, the fuzz
// corpus and benchmarks. Header-only so the corpus generator can build without the library.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <vector>

#include "sensor_rig/lidar/hesai/packet.hpp"

namespace sensor_rig::lidar::hesai::builder {

struct RawUnit {
  std::uint16_t distance = 0;  // units of 4 mm
  std::uint8_t reflectivity = 0;
};

enum class Kind : std::uint8_t { k40P, kXT32 };

struct PacketSpec {
  Kind kind = Kind::k40P;
  std::uint8_t return_mode = 0x37;
  int azimuth0 = 0;  // 0.01°, first azimuth group
  int step = 20;     // 0.01° per azimuth group
  std::function<RawUnit(int block, int channel)> unit;  // channel 0-based; empty: no returns
  std::array<std::uint8_t, 6> utc{23, 1, 11, 1, 2, 3};  // 40P: year - 2000; XT32: year - 1900 is set below
  std::uint32_t us = 0;
  std::uint8_t dis_unit = 4;  // XT32 header
  bool with_sequence = false;  // 40P: append the 4-byte UDP sequence
};

inline int returns_of(std::uint8_t mode) { return return_count(mode) == 2 ? 2 : 1; }

inline std::vector<std::byte> build_packet(const PacketSpec& s) {
  const int n = returns_of(s.return_mode);
  std::vector<std::byte> out;
  if (s.kind == Kind::k40P) {
    Packet40P p{};
    for (int b = 0; b < 10; ++b) {
      auto& blk = p.blocks[b];
      blk.sob[0] = 0xFF;
      blk.sob[1] = 0xEE;
      put_le16(blk.azimuth, static_cast<std::uint16_t>((s.azimuth0 + (b / n) * s.step) % kAzimuthCount));
      for (int c = 0; c < 40 && s.unit; ++c) {
        const RawUnit u = s.unit(b, c);
        put_le16(blk.units[c].distance, u.distance);
        blk.units[c].reflectivity = u.reflectivity;
      }
    }
    put_le16(p.tail.motor_speed, 600);
    put_le32(p.tail.timestamp, s.us);
    p.tail.return_mode = s.return_mode;
    p.tail.factory_info = 0x42;
    std::memcpy(p.tail.utc, s.utc.data(), 6);
    out.resize(sizeof p + (s.with_sequence ? 4 : 0));
    std::memcpy(out.data(), &p, sizeof p);
    return out;
  }
  PacketXT32 p{};
  p.header.sop[0] = 0xEE;
  p.header.sop[1] = 0xFF;
  p.header.protocol_major = 6;
  p.header.protocol_minor = 1;
  p.header.laser_num = 32;
  p.header.block_num = 8;
  p.header.dis_unit = s.dis_unit;
  p.header.return_num = static_cast<std::uint8_t>(n);
  for (int b = 0; b < 8; ++b) {
    auto& blk = p.blocks[b];
    put_le16(blk.azimuth, static_cast<std::uint16_t>((s.azimuth0 + (b / n) * s.step) % kAzimuthCount));
    for (int c = 0; c < 32 && s.unit; ++c) {
      const RawUnit u = s.unit(b, c);
      put_le16(blk.units[c].distance, u.distance);
      blk.units[c].reflectivity = u.reflectivity;
    }
  }
  p.tail.return_mode = s.return_mode;
  put_le16(p.tail.motor_speed, 600);
  std::memcpy(p.tail.utc, s.utc.data(), 6);
  p.tail.utc[0] = static_cast<std::uint8_t>(s.utc[0] + 100);  // XT32 counts years from 1900
  put_le32(p.tail.timestamp, s.us);
  out.resize(sizeof p);
  std::memcpy(out.data(), &p, sizeof p);
  return out;
}

}  // namespace sensor_rig::lidar::hesai::builder
