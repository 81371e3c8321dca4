#pragma once
// Ouster IMU packet (UDP port udp_port_imu, 7503 by default), the legacy 48-byte layout every
// LEGACY-profile sensor and the eUDP profiles' PROFILE_IMU_LEGACY send (ouster-sdk parsing.cpp:
// imu_sys_ts / imu_accel_ts / imu_gyro_ts u64 at 0/8/16, imu_la_{x,y,z} f32 at 24/28/32 in g,
// imu_av_{x,y,z} f32 at 36/40/44 in deg/s, little-endian, in the IMU's own frame). About 100 Hz.
// Pure parsing and encoding: no I/O, no clock; never throws.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace sensor_rig::lidar::ouster {

inline constexpr std::size_t kImuPacketSize = 48;
inline constexpr double kStandardGravity = 9.80665;  // m/s² per g (ouster-ros uses the same)

struct RawImuPacket {
  std::uint8_t sys_ts[8];    // sensor "system" time of the packet, ns
  std::uint8_t accel_ts[8];  // accelerometer sample time, ns (the sensor clock of the lidar columns)
  std::uint8_t gyro_ts[8];   // gyroscope sample time, ns
  std::uint8_t accel[3][4];  // IEEE-754 float, g
  std::uint8_t gyro[3][4];   // IEEE-754 float, deg/s
};
static_assert(sizeof(RawImuPacket) == kImuPacketSize);
static_assert(offsetof(RawImuPacket, accel) == 24);
static_assert(offsetof(RawImuPacket, gyro) == 36);

enum class ImuPacketStatus : std::uint8_t {
  kOk = 0,
  kWrongSize,  // anything but 48 bytes
  kNonFinite,  // a NaN or infinite acceleration / angular velocity: never published
};
const char* to_string(ImuPacketStatus s) noexcept;

// One IMU sample as the sensor sends it (its units and frame).
struct ImuSample {
  std::uint64_t sys_ts_ns = 0;
  std::uint64_t accel_ts_ns = 0;
  std::uint64_t gyro_ts_ns = 0;
  std::array<float, 3> accel_g{};   // x, y, z
  std::array<float, 3> gyro_dps{};  // x, y, z

  // SI units of sensor_msgs/Imu.
  [[nodiscard]] std::array<double, 3> linear_acceleration_mps2() const noexcept;
  [[nodiscard]] std::array<double, 3> angular_velocity_radps() const noexcept;
};

// kOk fills `out`; otherwise `out` is untouched.
ImuPacketStatus parse_imu_packet(std::span<const std::byte> bytes, ImuSample& out) noexcept;

// Writes the 48-byte packet (mock sensors, tests).
void encode_imu_packet(const ImuSample& s, std::span<std::byte, kImuPacketSize> out) noexcept;

}  // namespace sensor_rig::lidar::ouster
