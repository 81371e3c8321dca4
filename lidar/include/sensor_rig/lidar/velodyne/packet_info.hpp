#pragma once
// What a data packet's trailer says, read without decoding points.
#include <cstdint>
#include <optional>
#include <span>

#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::velodyne {

struct PacketInfo {
  std::uint32_t sensor_time_us = 0;  // µs since the top of the hour (sensor clock)
  std::uint8_t return_mode = 0;      // raw byte; see ReturnMode
  std::uint8_t product_id = 0;       // raw byte; see ProductId
  std::uint16_t first_azimuth = 0;   // hundredths of a degree
  [[nodiscard]] bool dual() const noexcept {
    return return_mode == static_cast<std::uint8_t>(ReturnMode::kDual);
  }
};

// nullopt unless `bytes` is exactly one data packet.
std::optional<PacketInfo> read_packet_info(std::span<const std::byte> bytes) noexcept;

// Vehicle time of a sensor timestamp: µs since the hour, with the hour taken from a reference
// time in the same clock (pcap record time, host receive time, GPRMC). The hour closest to the
// reference wins, so a reference a little before or after the hour boundary still maps right.
std::int64_t sensor_time_to_ns(std::uint32_t sensor_time_us, std::int64_t reference_ns) noexcept;

}  // namespace sensor_rig::lidar::velodyne
