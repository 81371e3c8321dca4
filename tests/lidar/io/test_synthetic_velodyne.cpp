// Synthetic Velodyne sensor: the packets are genuine (layout, flags, azimuth steps, timestamps at
// the model's firing rate, factory bytes, position packets), and decoding them with the real
// decoder reproduces the scene geometry within the sensor's resolution (round trip).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar::mock {
namespace {

using velodyne::Model;
using velodyne::ReturnMode;

constexpr Nanos kStart = 1'700'000'123'456'789'000LL;  // 2023-11-14 22:15:23.456789 UTC

struct Case {
  Model model;
  ReturnMode mode;
  double rpm;
  double expected_pps;  // packets per second from the user manuals
};

std::string name_of(const testing::TestParamInfo<Case>& i) {
  std::string n(velodyne::model_info(i.param.model).name);
  std::erase(n, '-');
  return n + (i.param.mode == ReturnMode::kDual ? "_dual_" : "_strongest_") + std::to_string(int(i.param.rpm));
}

class Synthetic : public testing::TestWithParam<Case> {
 protected:
  SyntheticVelodyne make(Nanos position_period = 1'000'000'000) const {
    SyntheticConfig c;
    c.model = GetParam().model;
    c.return_mode = GetParam().mode;
    c.rpm = GetParam().rpm;
    c.start_ns = kStart;
    c.start_azimuth_deg = 123.45;
    c.position_period_ns = position_period;
    return SyntheticVelodyne(c, Scene::standard());
  }
};

TEST_P(Synthetic, PacketRateMatchesManual) {
  const auto s = make();
  EXPECT_NEAR(s.packets_per_second(), GetParam().expected_pps, 1.0);
}

TEST_P(Synthetic, PacketsAreGenuine) {
  const auto s = make(0);
  const Case& p = GetParam();
  const bool dual = p.mode == ReturnMode::kDual;
  const auto& info = velodyne::model_info(p.model);
  // Azimuth advance per firing block in hundredths of a degree.
  const double step = p.rpm * 360.0 / 60.0 * info.block_us * 1e-6 * 100.0;
  std::array<std::byte, velodyne::kDataPacketSize> buf{};
  std::uint32_t prev_ts = 0;
  int prev_az = -1;
  std::size_t returns = 0;
  for (std::uint64_t k = 0; k < 400; ++k) {
    s.render_data_packet(k, buf);
    ASSERT_EQ(velodyne::check_packet(buf, p.model), PacketStatus::kOk) << "packet " << k;
    const auto pkt = velodyne::read_data_packet(buf);
    ASSERT_TRUE(pkt);
    EXPECT_EQ(pkt->return_mode, static_cast<std::uint8_t>(p.mode));
    EXPECT_EQ(pkt->product_id, static_cast<std::uint8_t>(info.product_id));
    for (std::size_t b = 0; b < velodyne::kBlocksPerPacket; ++b) {
      const auto& blk = pkt->blocks[b];
      ASSERT_EQ(blk.flag[0], 0xFF);
      ASSERT_EQ(blk.flag[1], 0xEE);
      const int az = velodyne::le16(blk.azimuth);
      ASSERT_LT(az, 36000);
      if (dual && b % 2 == 1) {
        EXPECT_EQ(std::memcmp(&blk, &pkt->blocks[b - 1], sizeof blk), 0) << "dual pair differs";
        continue;
      }
      if (prev_az >= 0) {
        const int d = (az - prev_az + 36000) % 36000;
        EXPECT_NEAR(d, step, 1.0) << "packet " << k << " block " << b;
      }
      prev_az = az;
      for (const auto& ch : blk.channels) returns += velodyne::le16(ch.distance) != 0 ? 1 : 0;
    }
    const std::uint32_t ts = velodyne::le32(pkt->timestamp);
    const Nanos t = s.data_packet_time(k);
    EXPECT_EQ(ts, static_cast<std::uint32_t>((t % 3'600'000'000'000LL) / 1000));
    if (k > 0) {
      EXPECT_NEAR(static_cast<double>(ts - prev_ts), s.packet_period_ns() / 1000.0, 1.0);
    }
    prev_ts = ts;
  }
  // Most beams see the ground, walls or boxes; the upper lasers look over the walls.
  const std::size_t channels = 400 * velodyne::kBlocksPerPacket / (dual ? 2 : 1) * velodyne::kChannelsPerBlock;
  EXPECT_GT(returns, channels / 2);
  EXPECT_LT(returns, channels);
}

TEST_P(Synthetic, StreamInterleavesPositionPacketsWithGprmc) {
  auto s = make(100'000'000);  // 10 Hz keeps the test short; the default is 1 Hz
  std::vector<SyntheticPacket> pos;
  Nanos prev = 0;
  std::uint64_t data = 0;
  while (true) {
    const SyntheticPacket pk = s.next();
    ASSERT_GE(pk.time_ns, prev);
    prev = pk.time_ns;
    if (pk.time_ns > kStart + 350'000'000LL) break;
    if (!pk.position) {
      ++data;
      ASSERT_EQ(pk.bytes.size(), velodyne::kDataPacketSize);
      continue;
    }
    velodyne::PositionPacket pp;
    ASSERT_EQ(velodyne::parse_position_packet(pk.bytes, pp), PacketStatus::kOk);
    EXPECT_EQ(pp.pps, velodyne::PpsState::kLocked);
    ASSERT_EQ(pp.nmea, velodyne::NmeaStatus::kOk);
    EXPECT_TRUE(pp.fix.valid);
    // GPRMC hour + µs since hour = the packet's time (to the µs).
    EXPECT_EQ(pp.fix.hour_start_ns + static_cast<Nanos>(pp.sensor_time_us) * 1000, pk.time_ns / 1000 * 1000);
    EXPECT_LE(pp.fix.utc_ns, pk.time_ns);
    EXPECT_GT(pp.fix.utc_ns, pk.time_ns - 1'000'000'000LL);
    pos.push_back(pk);
  }
  EXPECT_EQ(pos.size(), 4u);  // t = 0, 0.1, 0.2, 0.3 s
  EXPECT_NEAR(static_cast<double>(data), 0.35 * s.packets_per_second(), 2.0);
}

// Decoded synthetic packets reproduce the scene: every point lies on a scene surface within the
// range resolution plus the azimuth quantization (0.01°) at its range, carries that surface's
// reflectivity, and no return is lost or invented.
// The sensor renders each laser at its own firing time; the decoder's kPerLaser interpolation is
// that exact model. The default (VeloView's per-sequence interpolation) is checked against the
// azimuth the rotor covers within one firing sequence.
void round_trip(const Case& p, const SyntheticVelodyne& s, velodyne::AzimuthInterpolation interpolation);

TEST_P(Synthetic, RoundTripThroughDecoderReproducesScene) {
  round_trip(GetParam(), make(0), velodyne::AzimuthInterpolation::kPerLaser);
}

TEST_P(Synthetic, RoundTripWithPerSequenceInterpolation) {
  round_trip(GetParam(), make(0), velodyne::AzimuthInterpolation::kPerSequence);
}

void round_trip(const Case& p, const SyntheticVelodyne& s, velodyne::AzimuthInterpolation interpolation) {
  velodyne::DecoderConfig dc;
  dc.interpolation = interpolation;
  // Angle the decoder may be off by: block azimuth quantization (0.01°), plus for per-sequence
  // interpolation the rotation during one firing sequence.
  const auto& info = velodyne::model_info(p.model);
  const double seq_us = p.model == Model::kVLP16 ? info.block_us / 2 : info.block_us;
  const double angle_tol = interpolation == velodyne::AzimuthInterpolation::kPerLaser
                               ? 2.0e-4
                               : 2.0e-4 + p.rpm / 60.0 * 2 * std::numbers::pi * seq_us * 1e-6;
  dc.model = p.model;
  dc.returns = p.mode == ReturnMode::kDual ? velodyne::ReturnSelection::kDual : velodyne::ReturnSelection::kStrongest;
  dc.emit_partial_scans = true;
  velodyne::Decoder dec(dc);
  const double resolution = velodyne::default_calibration(p.model).distance_resolution_m;

  // 2.3 revolutions.
  const auto packets = static_cast<std::uint64_t>(2.3 * 60.0 / p.rpm * s.packets_per_second());
  std::array<std::byte, velodyne::kDataPacketSize> buf{};
  std::vector<Scan> scans;
  std::size_t expected_points = 0;
  for (std::uint64_t k = 0; k < packets; ++k) {
    s.render_data_packet(k, buf);
    const auto pkt = velodyne::read_data_packet(buf);
    const std::size_t step = p.mode == ReturnMode::kDual ? 2 : 1;
    for (std::size_t b = 0; b < velodyne::kBlocksPerPacket; b += step) {
      for (const auto& ch : pkt->blocks[b].channels) expected_points += velodyne::le16(ch.distance) != 0 ? 1 : 0;
    }
    const Nanos t = s.data_packet_time(k);
    if (auto scan = dec.push(PacketView{buf, t, velodyne::kDataPort}, t)) scans.push_back(std::move(*scan));
    EXPECT_EQ(dec.last_status(), PacketStatus::kOk);
  }
  if (auto last = dec.flush()) scans.push_back(std::move(*last));
  ASSERT_GE(scans.size(), 3u) << "partial, complete, complete, partial";

  std::size_t points = 0, off_surface = 0, wrong_intensity = 0;
  double worst = 0;
  const auto& surfaces = s.scene().surfaces();
  for (const Scan& scan : scans) {
    for (const PointXYZIRT& pt : scan.points) {
      ++points;
      const Vec3 v{static_cast<double>(pt.x), static_cast<double>(pt.y), static_cast<double>(pt.z)};
      const double range = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
      const double tol = resolution / 2 + range * angle_tol + 5e-4;
      std::size_t which = 0;
      const double d = s.scene().distance_to_surface(v, &which);
      worst = std::max(worst, d / tol);
      if (d > tol) {
        ++off_surface;
        continue;
      }
      bool match = false;  // at an edge, any surface within tolerance may be the one hit
      for (const Surface& surf : surfaces) {
        if (surf.reflectivity == static_cast<std::uint8_t>(pt.intensity)) {
          Scene one;
          one.add(surf);
          match = match || one.distance_to_surface(v) <= tol;
        }
      }
      wrong_intensity += match ? 0 : 1;
    }
  }
  EXPECT_EQ(points, expected_points);
  EXPECT_EQ(off_surface, 0u) << "worst distance / tolerance " << worst;
  EXPECT_EQ(wrong_intensity, 0u);

  // Each complete scan spans one revolution, starts at the cut and is stamped at its first firing.
  const Nanos rev_ns = static_cast<Nanos>(60e9 / p.rpm);
  for (std::size_t i = 1; i + 1 < scans.size(); ++i) {
    EXPECT_NEAR(static_cast<double>(scans[i + 1].stamp - scans[i].stamp), static_cast<double>(rev_ns),
                s.packet_period_ns());
    EXPECT_NEAR(static_cast<double>(scans[i].points.size()), static_cast<double>(scans[1].points.size()),
                0.01 * static_cast<double>(scans[1].points.size()));
  }
  // At 0° (cut angle) the sensor's azimuth wraps: the scan's first firing is near it.
  const double az_first = s.azimuth_deg_at(scans[1].stamp);
  EXPECT_LT(std::min(az_first, 360.0 - az_first), 1.0);
}

INSTANTIATE_TEST_SUITE_P(Models, Synthetic,
                         testing::Values(Case{Model::kVLP16, ReturnMode::kStrongest, 600, 753.5},
                                         Case{Model::kVLP16, ReturnMode::kDual, 600, 1507.0},
                                         Case{Model::kVLP16, ReturnMode::kStrongest, 1200, 753.5},
                                         Case{Model::kVLP32C, ReturnMode::kStrongest, 600, 1507.0},
                                         Case{Model::kVLP32C, ReturnMode::kDual, 900, 3014.0},
                                         Case{Model::kHDL32E, ReturnMode::kStrongest, 600, 1808.4},
                                         Case{Model::kHDL32E, ReturnMode::kDual, 300, 3616.9}),
                         name_of);

TEST(SyntheticConfig, RejectsBadRpm) {
  SyntheticConfig c;
  c.rpm = 5000;
  EXPECT_THROW(SyntheticVelodyne(c, Scene::standard()), std::invalid_argument);
  c.rpm = std::nan("");
  EXPECT_THROW(SyntheticVelodyne(c, Scene::standard()), std::invalid_argument);
}

TEST(Scene, CastsAndMeasuresDistance) {
  const Scene sc = Scene::standard();
  // Straight down: ground at 1.8 m.
  auto hit = sc.cast({0, 0, 0}, {0, 0, -1}, 100);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->range, 1.8, 1e-9);
  EXPECT_EQ(sc.surfaces()[hit->surface].name, "ground");
  // Forward at sensor height: the car's rear face at x = 7 is off-axis (y in [-4,-2.2]); +x wall at 30.
  hit = sc.cast({0, 0, 0}, {1, 0, 0}, 100);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->range, 30.0, 1e-9);
  // Towards the car's rear face at (7, -3, -1); at sensor height the ray would pass over its roof.
  const double n = std::sqrt(7.0 * 7.0 + 3.0 * 3.0 + 1.0);
  hit = sc.cast({0, 0, 0}, {7.0 / n, -3.0 / n, -1.0 / n}, 100);
  ASSERT_TRUE(hit);
  EXPECT_EQ(sc.surfaces()[hit->surface].name, "car");
  EXPECT_NEAR(hit->range, n, 1e-9);
  // Up: nothing.
  EXPECT_FALSE(sc.cast({0, 0, 0}, {0, 0, 1}, 100));
  // Max range.
  EXPECT_FALSE(sc.cast({0, 0, 0}, {1, 0, 0}, 20));
  EXPECT_NEAR(sc.distance_to_surface({5, 5, -1.7}), 0.1, 1e-9);
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
