// The LIDAR node's second port, in one process over real loopback UDP and a real DDS participant:
// Ouster IMU packets -> sensor_msgs/Imu on /sensors/lidar/<name>/imu (SI units, stamped through
// timesync, no orientation), Velodyne position packets -> sensor_msgs/NavSatFix on
// /sensors/lidar/<name>/fix (one message per new $GPRMC; void / empty fields = STATUS_NO_FIX;
// bad checksum, malformed sentences and wrong-size packets counted, never published).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include "lidar_node_reader.hpp"
#include "rig_process.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/ouster/imu_packet.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "sensor_rig/lidar/velodyne/position_packet.hpp"
#include "status_value.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

namespace vel = lidar::velodyne;
std::string unique(const std::string& base) { return base + "_" + std::to_string(::getpid()); }

std::vector<std::byte> imu_bytes(const lidar::ouster::ImuSample& s) {
  std::vector<std::byte> b(lidar::ouster::kImuPacketSize);
  lidar::ouster::encode_imu_packet(s, std::span<std::byte, lidar::ouster::kImuPacketSize>(b.data(), b.size()));
  return b;
}

struct ImuSeen {
  Nanos stamp;
  std::string frame;
  double ax, ay, az, wx, wy, wz, orientation_cov0;
};

// With `source: packet` the ring on `lo` takes the IMU port too (no socket on it): the same result.
void ouster_imu_packets_become_imu(LidarSource source) {
  test::TempDir dir;
  lidar::mock::NominalOuster n;
  const auto meta = dir.write("os.json", lidar::mock::metadata_json(lidar::mock::nominal_ouster_metadata(n)));
  LidarConfig c;
  c.name = unique("imu");
  c.model = "OS-LEGACY";
  c.metadata = meta;
  c.port = test::free_udp_port();
  c.position_port = test::free_udp_port();  // imu_port in the config
  c.time_source = timesync::TimeSource::kSensor;
  c.frame_id = "lidar_" + c.name;
  if (source == LidarSource::kPacket) {
    c.source = source;
    c.interface = "lo";
  }

  std::unique_ptr<test::LidarNodeReader<msg::Imu>> made;
  try {
    made = std::make_unique<test::LidarNodeReader<msg::Imu>>(c, "imu", 100);
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "AF_PACKET ring not permitted here: " << e.what();
  }
  auto& node = *made;
  ASSERT_TRUE(node.start());
  auto& reader = node.reader;
  auto& driver = node.driver;

  const std::vector<lidar::Endpoint> dest{{"127.0.0.1", static_cast<std::uint16_t>(c.position_port)}};
  lidar::UdpSender sender(dest);
  // A PTP-synced sensor: sample times are vehicle time (the time of sending).
  constexpr int kGood = 5;
  std::vector<Nanos> gyro_times;
  for (int k = 0; k < kGood; ++k) {
    lidar::ouster::ImuSample s;
    s.sys_ts_ns = s.accel_ts_ns = static_cast<std::uint64_t>(vehicle_now_ns());
    gyro_times.push_back(static_cast<Nanos>(s.accel_ts_ns) + 1000);
    s.gyro_ts_ns = s.accel_ts_ns + 1000;  // the stamp is the gyro's time (as ouster-ros)
    s.accel_g = {0.5F, -0.25F, 1.0F + static_cast<float>(k)};
    s.gyro_dps = {10.0F, -20.0F, 90.0F};
    sender.send(imu_bytes(s));
    // Adversarial: short, long, and a NaN acceleration; none may reach the topic.
    auto b = imu_bytes(s);
    if (k == 1) sender.send(std::span<const std::byte>(b.data(), b.size() - 1));
    if (k == 2) {
      b.push_back(std::byte{0});
      sender.send(b);
    }
    if (k == 3) {
      const float nan = std::numeric_limits<float>::quiet_NaN();
      std::memcpy(b.data() + 28, &nan, 4);  // imu_la_y
      sender.send(b);
    }
    ::usleep(10'000);  // 100 Hz
  }
  std::vector<ImuSeen> seen;
  ASSERT_TRUE(wait_for(
      [&] {
        reader.take([&](const msg::Imu& m, const dds_sample_info_t&) {
          seen.push_back({msg::from_time(m.header.stamp), m.header.frame_id, m.linear_acceleration.x,
                          m.linear_acceleration.y, m.linear_acceleration.z, m.angular_velocity.x, m.angular_velocity.y,
                          m.angular_velocity.z, m.orientation_covariance[0]});
        });
        return seen.size() >= kGood;
      },
      3000))
      << seen.size();
  ::usleep(100'000);
  reader.take([&](const msg::Imu&, const dds_sample_info_t&) { ADD_FAILURE() << "a bad IMU packet was published"; });
  constexpr double kG = 9.80665, kD2r = std::numbers::pi / 180.0;
  int exact = 0;
  for (int k = 0; k < kGood; ++k) {
    const auto& m = seen[static_cast<std::size_t>(k)];
    EXPECT_EQ(m.frame, c.frame_id + "_imu");
    EXPECT_DOUBLE_EQ(m.orientation_cov0, -1.0);
    EXPECT_NEAR(m.ax, 0.5 * kG, 1e-9);
    EXPECT_NEAR(m.ay, -0.25 * kG, 1e-9);
    EXPECT_NEAR(m.az, (1.0 + k) * kG, 1e-6);
    EXPECT_NEAR(m.wx, 10 * kD2r, 1e-7);
    EXPECT_NEAR(m.wy, -20 * kD2r, 1e-7);
    EXPECT_NEAR(m.wz, 90 * kD2r, 1e-6);
    // Through timesync: the device clock agrees with the host, so its gyro time is taken as is.
    // Until the mapper has seen a few samples a stamp may sit at a receive time: on a loaded host
    // this test can be descheduled between reading the clock and sending (seen: 53 ms, first three
    // samples), so early samples are only bounded; the last one is the converged mapping.
    const Nanos gyro = gyro_times[static_cast<std::size_t>(k)];
    EXPECT_NEAR(static_cast<double>(m.stamp - gyro), 0.0, k + 1 == kGood ? 2e6 : 200e6) << k;
    exact += m.stamp == gyro ? 1 : 0;  // sensor_synced: the gyro's own time (not the accel's, 1 µs before)
  }
  EXPECT_GE(exact, 1);
  ASSERT_TRUE(wait_for([&] { return test::status_value(driver.status(), "imu_dropped_non_finite") == "1"; }, 30'000));
  const auto st = driver.status();
  EXPECT_EQ(test::status_value(st, "imu_samples"), "5");
  EXPECT_EQ(test::status_value(st, "imu_dropped_wrong_size"), "2");
  EXPECT_EQ(test::status_value(st, "imu_topic"), "/sensors/lidar/" + c.name + "/imu");
  if (source == LidarSource::kPacket) {
    EXPECT_EQ(test::status_value(st, "ring_second_port_packets"), "8");
  }
  driver.stop();
}

TEST(LidarSideTopics, OusterImuPacketsBecomeImuInSiUnits) { ouster_imu_packets_become_imu(LidarSource::kUdp); }

TEST(LidarSideTopics, OusterImuThroughThePacketRing) { ouster_imu_packets_become_imu(LidarSource::kPacket); }

std::vector<std::byte> position_bytes(const std::string& sentence, vel::PpsState pps = vel::PpsState::kLocked) {
  std::vector<std::byte> b(lidar::velodyne::kPositionPacketSize);
  vel::encode_position_packet(1234, pps, sentence, std::span<std::byte, lidar::velodyne::kPositionPacketSize>(b.data(), b.size()));
  return b;
}

std::string with_checksum(const std::string& body) {  // body without '$'
  char tail[8];
  std::snprintf(tail, sizeof tail, "*%02X\r\n", vel::nmea_checksum(body));
  return "$" + body + tail;
}

struct FixSeen {
  Nanos stamp;
  std::string frame;
  int status, service;
  double lat, lon, alt;
};

TEST(LidarSideTopics, VelodyneGprmcBecomesNavSatFixAndBadSentencesAreCounted) {
  LidarConfig c;
  c.name = unique("fix");
  c.model = "VLP-16";
  c.port = test::free_udp_port();
  c.position_port = test::free_udp_port();
  c.time_source = timesync::TimeSource::kSensor;
  c.frame_id = "lidar_" + c.name;

  test::LidarNodeReader<msg::NavSatFix> node(c, "fix", 100);
  ASSERT_TRUE(node.start());
  auto& reader = node.reader;
  auto& driver = node.driver;
  const std::vector<lidar::Endpoint> dest{{"127.0.0.1", static_cast<std::uint16_t>(c.position_port)}};
  lidar::UdpSender sender(dest);

  const Nanos t0 = 1'700'000'000'000'000'000LL;  // 2023-11-14T22:13:20Z
  vel::RmcInput fix{t0, true, 48.7758, 9.1829};
  const std::string good = vel::format_rmc(fix);
  std::string flipped = good;
  flipped[20] = static_cast<char>(flipped[20] ^ 0x01);  // one bit in the latitude: checksum catches it
  vel::RmcInput void_fix{t0 + 1'000'000'000, false, 48.7758, 9.1829};
  const std::string empty = with_checksum("GPRMC,221322,A,,,,,000.0,000.0,141123,,,A");
  const std::string not_valid_mode = with_checksum("GPRMC,221323,A,4846.5480,N,00910.9740,E,000.0,000.0,141123,,,N");
  const std::string hdl32e = "$GPRMC,220632,A,3707.8324,N,12139.2864,W,000.0,144.7,111212,013.8,E,D*09\r\n";
  std::vector<std::vector<std::byte>> packets = {
      position_bytes(good), position_bytes(good), position_bytes(good),  // repeated: one message
      position_bytes(flipped),                                            // bad checksum
      position_bytes(vel::format_rmc(void_fix)),                          // V: no fix
      position_bytes(empty),                                              // A without coordinates: no fix
      position_bytes(good.substr(0, good.find('*'))),                     // truncated: malformed
      position_bytes(not_valid_mode),                                     // mode N: no fix
      position_bytes(""),                                                 // no GPS: nothing
      position_bytes(hdl32e),                                             // a real sensor's sentence
  };
  packets.emplace_back(511, std::byte{0});  // wrong size
  for (const auto& b : packets) {
    sender.send(b);
    ::usleep(1000);
  }
  std::vector<FixSeen> seen;
  ASSERT_TRUE(wait_for(
      [&] {
        reader.take([&](const msg::NavSatFix& m, const dds_sample_info_t&) {
          seen.push_back({msg::from_time(m.header.stamp), m.header.frame_id, m.status.status, m.status.service,
                          m.latitude, m.longitude, m.altitude});
        });
        return seen.size() >= 5;
      },
      3000))
      << seen.size();
  ::usleep(100'000);
  reader.take([&](const msg::NavSatFix&, const dds_sample_info_t&) { ADD_FAILURE() << "more fixes than sentences"; });
  ASSERT_EQ(seen.size(), 5u);
  for (const auto& f : seen) {
    EXPECT_EQ(f.frame, c.frame_id + "_gps");
    EXPECT_EQ(f.service, 1);
    EXPECT_TRUE(std::isnan(f.alt));
  }
  EXPECT_EQ(seen[0].status, 0);
  EXPECT_NEAR(seen[0].lat, 48.7758, 2e-6);
  EXPECT_NEAR(seen[0].lon, 9.1829, 2e-6);
  EXPECT_EQ(seen[0].stamp, t0);
  for (std::size_t i : {1u, 2u, 3u}) {
    EXPECT_EQ(seen[i].status, -1) << i;
    EXPECT_TRUE(std::isnan(seen[i].lat) && std::isnan(seen[i].lon)) << i;
  }
  EXPECT_EQ(seen[1].stamp, t0 + 1'000'000'000);
  EXPECT_EQ(seen[2].stamp, t0 + 2'000'000'000);
  EXPECT_EQ(seen[4].status, 0);
  EXPECT_NEAR(seen[4].lat, 37.0 + 7.8324 / 60.0, 1e-9);
  EXPECT_NEAR(seen[4].lon, -(121.0 + 39.2864 / 60.0), 1e-9);

  ASSERT_TRUE(wait_for([&] { return test::status_value(driver.status(), "position_dropped_wrong_size") == "1"; }, 30'000));
  const auto st = driver.status();
  EXPECT_EQ(test::status_value(st, "fixes"), "5");
  EXPECT_EQ(test::status_value(st, "fixes_no_fix"), "3");
  EXPECT_EQ(test::status_value(st, "gprmc_bad_checksum"), "1");
  EXPECT_EQ(test::status_value(st, "gprmc_malformed"), "1");
  EXPECT_EQ(test::status_value(st, "position_packets"), "10");
  driver.stop();
}

}  // namespace
}  // namespace sensor_rig::drivers
