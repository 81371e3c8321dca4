#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar::velodyne {

std::optional<PacketInfo> read_packet_info(std::span<const std::byte> bytes) noexcept {
  if (bytes.size() != kDataPacketSize) return std::nullopt;
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  PacketInfo info;
  info.sensor_time_us = le32(p + offsetof(RawDataPacket, timestamp));
  info.return_mode = p[offsetof(RawDataPacket, return_mode)];
  info.product_id = p[offsetof(RawDataPacket, product_id)];
  info.first_azimuth = le16(p + offsetof(RawBlock, azimuth));
  return info;
}

std::int64_t sensor_time_to_ns(std::uint32_t sensor_time_us, std::int64_t reference_ns) noexcept {
  constexpr std::int64_t kHour = 3'600'000'000'000LL;
  std::int64_t hour = reference_ns - (reference_ns % kHour + kHour) % kHour;
  const std::int64_t in_hour = static_cast<std::int64_t>(sensor_time_us) * 1000;
  std::int64_t best = hour + in_hour;
  for (const std::int64_t h : {hour - kHour, hour + kHour}) {
    const std::int64_t candidate = h + in_hour;
    const auto dist = [&](std::int64_t v) { return v > reference_ns ? v - reference_ns : reference_ns - v; };
    if (dist(candidate) < dist(best)) best = candidate;
  }
  return best;
}

}  // namespace sensor_rig::lidar::velodyne
