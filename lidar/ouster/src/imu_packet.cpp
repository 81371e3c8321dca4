// Ouster legacy IMU packet (see imu_packet.hpp). Pure: no I/O, no clock.
#include "sensor_rig/lidar/ouster/imu_packet.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

namespace sensor_rig::lidar::ouster {
namespace {

std::uint64_t get_le64(const std::uint8_t* p) noexcept {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
void put_le64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF);
}
float get_f32(const std::uint8_t* p) noexcept {
  std::uint32_t w = 0;
  for (int i = 0; i < 4; ++i) w |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return std::bit_cast<float>(w);
}
void put_f32(std::uint8_t* p, float f) noexcept {
  const auto w = std::bit_cast<std::uint32_t>(f);
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>((w >> (8 * i)) & 0xFF);
}

}  // namespace

const char* to_string(ImuPacketStatus s) noexcept {
  switch (s) {
    case ImuPacketStatus::kOk: return "ok";
    case ImuPacketStatus::kWrongSize: return "wrong_size";
    case ImuPacketStatus::kNonFinite: return "non_finite";
  }
  return "unknown";
}

std::array<double, 3> ImuSample::linear_acceleration_mps2() const noexcept {
  return {static_cast<double>(accel_g[0]) * kStandardGravity, static_cast<double>(accel_g[1]) * kStandardGravity,
          static_cast<double>(accel_g[2]) * kStandardGravity};
}

std::array<double, 3> ImuSample::angular_velocity_radps() const noexcept {
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  return {static_cast<double>(gyro_dps[0]) * kRadPerDeg, static_cast<double>(gyro_dps[1]) * kRadPerDeg,
          static_cast<double>(gyro_dps[2]) * kRadPerDeg};
}

ImuPacketStatus parse_imu_packet(std::span<const std::byte> bytes, ImuSample& out) noexcept {
  if (bytes.size() != kImuPacketSize) return ImuPacketStatus::kWrongSize;
  RawImuPacket raw;
  std::memcpy(&raw, bytes.data(), sizeof raw);
  ImuSample s;
  s.sys_ts_ns = get_le64(raw.sys_ts);
  s.accel_ts_ns = get_le64(raw.accel_ts);
  s.gyro_ts_ns = get_le64(raw.gyro_ts);
  for (std::size_t i = 0; i < 3; ++i) {
    s.accel_g[i] = get_f32(raw.accel[i]);
    s.gyro_dps[i] = get_f32(raw.gyro[i]);
    if (!std::isfinite(s.accel_g[i]) || !std::isfinite(s.gyro_dps[i])) return ImuPacketStatus::kNonFinite;
  }
  out = s;
  return ImuPacketStatus::kOk;
}

void encode_imu_packet(const ImuSample& s, std::span<std::byte, kImuPacketSize> out) noexcept {
  RawImuPacket raw{};
  put_le64(raw.sys_ts, s.sys_ts_ns);
  put_le64(raw.accel_ts, s.accel_ts_ns);
  put_le64(raw.gyro_ts, s.gyro_ts_ns);
  for (std::size_t i = 0; i < 3; ++i) {
    put_f32(raw.accel[i], s.accel_g[i]);
    put_f32(raw.gyro[i], s.gyro_dps[i]);
  }
  std::memcpy(out.data(), &raw, sizeof raw);
}

}  // namespace sensor_rig::lidar::ouster
