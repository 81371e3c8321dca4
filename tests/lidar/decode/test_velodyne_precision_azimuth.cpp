// The default per-laser azimuth against points computed by hand from the manuals' "precision
// azimuth" formulas (independent of the decoder's tables):
//   VLP-16:  A(L, K) = A_block + gap * (2.304 µs * L + 55.296 µs * K) / 110.592 µs   (K: firing sequence)
//   VLP-32C: A(L)    = A_block + gap * (2.304 µs * floor(L / 2)) / 55.296 µs         (lasers fire in pairs)
//   HDL-32E: A(L)    = A_block + gap * (1.152 µs * L) / 46.08 µs
// gap = the next block's azimuth - this block's. Point: x_v = d cos(v) sin(A), y_v = d cos(v) cos(A),
// z = d sin(v) (Velodyne frame, x right, y forward), REP 103 = (y_v, -x_v, z). The decoder reads
// azimuths through a 0.01° table like the ROS driver: each direction is within 0.005° of the formula.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "sensor_rig/lidar/mock/velodyne_packet_builder.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"

namespace sensor_rig::lidar::test {
namespace {

using velodyne::Model;
using velodyne_builder::PacketBuilder;

constexpr double kDeg = std::numbers::pi / 180.0;

struct Case {
  Model model;
  velodyne::ProductId pid;
  int channel;       // position in the block (VLP-16: 16..31 = second firing sequence)
  double expected_offset_us;  // the manual's firing time of that channel within the block
  double block_us;
};

// A calibration with only elevations (the manual's), so the direction is the azimuth formula's.
velodyne::DecoderConfig config(Model m, velodyne::AzimuthInterpolation a) {
  velodyne::DecoderConfig cfg;
  cfg.model = m;
  auto cal = velodyne::default_calibration(m);
  for (auto& l : cal.lasers) {
    l.rot_correction = 0.0;
    l.vert_offset_correction = 0.0;
    l.horiz_offset_correction = 0.0;
    l.dist_correction = 0.0;
  }
  cfg.calibration = cal;
  cfg.interpolation = a;
  cfg.emit_partial_scans = true;
  return cfg;
}

std::vector<PointXYZIRT> decode(const velodyne::DecoderConfig& cfg, const PacketBuilder& b) {
  velodyne::Decoder dec(cfg);
  const auto bytes = b.bytes();
  EXPECT_FALSE(dec.push(PacketView{bytes, 0, velodyne::kDataPort}, 1'000'000'000));
  auto s = dec.flush();
  return s ? s->points : std::vector<PointXYZIRT>{};
}

class PrecisionAzimuth : public ::testing::TestWithParam<Case> {};

TEST_P(PrecisionAzimuth, MatchesTheManualsFormula) {
  const Case c = GetParam();
  const int a0 = 12345;  // 123.45°
  for (const int step : {20, 40, 77}) {  // 0.2°, 0.4°, 0.77° per block (5 .. 20 Hz)
    PacketBuilder b(c.pid);
    b.azimuths(a0, step);
    constexpr std::uint16_t kRaw = 10000;  // 20 m at 2 mm, 40 m at 4 mm
    b.ret(0, static_cast<std::size_t>(c.channel), kRaw, 9);
    const auto cfg = config(c.model, velodyne::AzimuthInterpolation::kPerLaser);
    const auto pts = decode(cfg, b);
    ASSERT_EQ(pts.size(), 1U);
    const int laser = c.model == Model::kVLP16 ? c.channel % 16 : c.channel;
    const double v = cfg.calibration->lasers[static_cast<std::size_t>(laser)].vert_correction;
    const double d = kRaw * cfg.calibration->distance_resolution_m;
    const double az_deg = (a0 + step * c.expected_offset_us / c.block_us) / 100.0;
    const double xv = d * std::cos(v) * std::sin(az_deg * kDeg);
    const double yv = d * std::cos(v) * std::cos(az_deg * kDeg);
    const double tol = d * 0.005 * kDeg + 1e-4;  // the 0.01° table (as the ROS driver's)
    EXPECT_NEAR(pts[0].x, yv, tol) << "step " << step;
    EXPECT_NEAR(pts[0].y, -xv, tol) << "step " << step;
    EXPECT_NEAR(pts[0].z, d * std::sin(v), 1e-4);
    EXPECT_EQ(pts[0].t, static_cast<std::uint32_t>(std::lround(c.expected_offset_us * 1000.0)));
    // VeloView's per-sequence convention: the sequence start instead (VLP-16 K * 55.296 µs, else 0).
    const auto seq = decode(config(c.model, velodyne::AzimuthInterpolation::kPerSequence), b);
    ASSERT_EQ(seq.size(), 1U);
    // NOLINTNEXTLINE(bugprone-integer-division): the firing sequence (0 or 1) the channel is in
    const double seq_us = c.model == Model::kVLP16 ? static_cast<double>(c.channel / 16) * 55.296 : 0.0;
    const double az_seq = (a0 + step * seq_us / c.block_us) / 100.0 * kDeg;
    EXPECT_NEAR(seq[0].x, d * std::cos(v) * std::cos(az_seq), tol) << "step " << step;
    EXPECT_NEAR(seq[0].y, -d * std::cos(v) * std::sin(az_seq), tol) << "step " << step;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Manuals, PrecisionAzimuth,
    ::testing::Values(
        // VLP-16: channel 0 fires first; 15 = laser 15 of sequence 0; 31 = laser 15 of sequence 1.
        Case{Model::kVLP16, velodyne::ProductId::kVLP16, 0, 0.0, 110.592},
        Case{Model::kVLP16, velodyne::ProductId::kVLP16, 7, 7 * 2.304, 110.592},
        Case{Model::kVLP16, velodyne::ProductId::kVLP16, 31, 15 * 2.304 + 55.296, 110.592},
        // VLP-32C: lasers 30 and 31 are the 16th pair.
        Case{Model::kVLP32C, velodyne::ProductId::kVLP32C, 5, 2 * 2.304, 55.296},
        Case{Model::kVLP32C, velodyne::ProductId::kVLP32C, 31, 15 * 2.304, 55.296},
        // HDL-32E: one laser every 1.152 µs.
        Case{Model::kHDL32E, velodyne::ProductId::kHDL32E, 1, 1.152, 46.08},
        Case{Model::kHDL32E, velodyne::ProductId::kHDL32E, 31, 31 * 1.152, 46.08}));

TEST(PrecisionAzimuthDefault, PerLaserIsTheDefault) {
  EXPECT_EQ(velodyne::DecoderConfig{}.interpolation, velodyne::AzimuthInterpolation::kPerLaser);
}

}  // namespace
}  // namespace sensor_rig::lidar::test
