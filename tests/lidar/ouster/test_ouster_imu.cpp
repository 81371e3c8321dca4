// Ouster IMU packets: the legacy 48-byte layout read from bytes placed at ouster-sdk's offsets
// (independent of the encoder), SI conversion, bad sizes and non-finite values as statuses, and the
// synthetic Ouster's IMU stream (100 Hz, time-ordered with the lidar packets, second port).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <vector>

#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/ouster/imu_packet.hpp"
#include "sensor_rig/lidar/ouster/decoder.hpp"

namespace sensor_rig::lidar::ouster {
namespace {

// ouster-sdk parsing.cpp: imu_sys_ts @0, imu_accel_ts @8, imu_gyro_ts @16 (u64), imu_la_x/y/z @24/28/32,
// imu_av_x/y/z @36/40/44 (f32), little-endian (this host is little-endian: memcpy places them).
std::vector<std::byte> sdk_layout(std::uint64_t sys, std::uint64_t acc, std::uint64_t gyr, const float (&la)[3],
                                  const float (&av)[3]) {
  std::vector<std::byte> b(48);
  std::memcpy(b.data() + 0, &sys, 8);
  std::memcpy(b.data() + 8, &acc, 8);
  std::memcpy(b.data() + 16, &gyr, 8);
  for (int i = 0; i < 3; ++i) {
    std::memcpy(b.data() + 24 + 4 * i, &la[i], 4);
    std::memcpy(b.data() + 36 + 4 * i, &av[i], 4);
  }
  return b;
}

TEST(OusterImu, ReadsTheSdkLayoutAndConvertsToSi) {
  const auto b = sdk_layout(111, 222, 333, {0.01F, -0.02F, 0.98F}, {1.5F, -3.0F, 180.0F});
  ImuSample s;
  ASSERT_EQ(parse_imu_packet(b, s), ImuPacketStatus::kOk);
  EXPECT_EQ(s.sys_ts_ns, 111u);
  EXPECT_EQ(s.accel_ts_ns, 222u);
  EXPECT_EQ(s.gyro_ts_ns, 333u);
  EXPECT_FLOAT_EQ(s.accel_g[2], 0.98F);
  EXPECT_FLOAT_EQ(s.gyro_dps[1], -3.0F);
  const auto a = s.linear_acceleration_mps2();
  const auto w = s.angular_velocity_radps();
  EXPECT_NEAR(a[0], 0.01 * 9.80665, 1e-7);
  EXPECT_NEAR(a[1], -0.02 * 9.80665, 1e-7);
  EXPECT_NEAR(a[2], 0.98 * 9.80665, 1e-6);
  EXPECT_NEAR(w[0], 1.5 * std::numbers::pi / 180, 1e-9);
  EXPECT_NEAR(w[2], std::numbers::pi, 1e-6);
  // The encoder writes what the parser reads, byte for byte.
  std::vector<std::byte> again(48);
  encode_imu_packet(s, std::span<std::byte, kImuPacketSize>(again.data(), 48));
  EXPECT_EQ(again, b);
}

TEST(OusterImu, BadPacketsAreStatusesAndLeaveTheOutputAlone) {
  const auto good = sdk_layout(1, 2, 3, {0.F, 0.F, 1.F}, {0.F, 0.F, 0.F});
  ImuSample s;
  s.sys_ts_ns = 77;
  for (std::size_t n : {0UL, 1UL, 47UL, 49UL, 6464UL}) {
    std::vector<std::byte> b(n);
    if (n > 0) std::memcpy(b.data(), good.data(), std::min<std::size_t>(n, 48));  // an empty vector's data() may be null
    EXPECT_EQ(parse_imu_packet(b, s), ImuPacketStatus::kWrongSize) << n;
  }
  for (int field = 0; field < 6; ++field) {
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
      auto b = good;
      std::memcpy(b.data() + 24 + 4 * field, &bad, 4);
      EXPECT_EQ(parse_imu_packet(b, s), ImuPacketStatus::kNonFinite) << field;
    }
  }
  // A flipped exponent bit of a float turns 1 g into a non-finite value or a finite one: each is
  // either refused or read as exactly what the bytes say (no checksum in this packet).
  auto b = good;
  b[24 + 8 + 3] = static_cast<std::byte>(static_cast<unsigned>(b[24 + 8 + 3]) ^ 0x40U);  // la_z exponent MSB
  EXPECT_EQ(parse_imu_packet(b, s), ImuPacketStatus::kNonFinite);
  EXPECT_EQ(s.sys_ts_ns, 77u);  // untouched by every refusal
  EXPECT_STREQ(to_string(ImuPacketStatus::kNonFinite), "non_finite");
}

TEST(OusterImu, SyntheticOusterSendsImuAt100HzInTimeOrderOnTheSecondPort) {
  mock::NominalOuster n;
  mock::SyntheticOusterConfig c;
  c.metadata = mock::nominal_ouster_metadata(n);
  c.start_ns = 1'700'000'000'000'000'000LL;
  c.imu_period_ns = 10'000'000;
  c.imu_accel_g = {0.1F, 0.2F, 1.0F};
  c.imu_gyro_dps = {0.5F, 0.0F, -0.5F};
  mock::SyntheticOuster s(c, mock::Scene::standard());
  DecoderConfig dc;
  dc.metadata = c.metadata;
  Decoder dec(dc);
  Nanos prev = 0;
  std::size_t imu = 0, lidar = 0, scans = 0;
  Nanos first_imu = 0, last_imu = 0;
  while (lidar < 640) {  // one second of a 1024x10 sensor
    const auto p = s.next();
    EXPECT_GE(p.time_ns, prev);
    prev = p.time_ns;
    if (p.position) {
      ImuSample m;
      ASSERT_EQ(parse_imu_packet(p.bytes, m), ImuPacketStatus::kOk);
      EXPECT_EQ(m.gyro_ts_ns, static_cast<std::uint64_t>(p.time_ns));
      EXPECT_EQ(m.accel_ts_ns, m.gyro_ts_ns);
      EXPECT_FLOAT_EQ(m.accel_g[1], 0.2F);
      EXPECT_FLOAT_EQ(m.gyro_dps[2], -0.5F);
      if (imu == 0) first_imu = p.time_ns;
      last_imu = p.time_ns;
      ++imu;
      continue;
    }
    ++lidar;
    if (dec.push(PacketView{p.bytes, p.time_ns, 7502}, p.time_ns)) ++scans;
  }
  EXPECT_EQ(imu, 100u);  // 1 s at 100 Hz (the first at the first lidar packet's time)
  EXPECT_EQ(last_imu - first_imu, 99 * 10'000'000LL);
  EXPECT_EQ(scans, 10u);  // lidar stream unchanged by the interleaving
  EXPECT_EQ(dec.stats().dropped(), 0u);
  EXPECT_EQ(s.imu_packets_emitted(), 100u);
}

}  // namespace
}  // namespace sensor_rig::lidar::ouster
