// Decoder behaviour on crafted packets: geometry (REP 103), rings, per-point time, scan cuts,
// return modes, range limits and counted drops.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "sensor_rig/lidar/mock/velodyne_packet_builder.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar::test {
namespace {

using namespace velodyne_builder;  // NOLINT(google-build-using-namespace): the packet builder

using velodyne::Decoder;
using velodyne::DecoderConfig;
using velodyne::Model;
using velodyne::ProductId;
using velodyne::ReturnMode;
using velodyne::ReturnSelection;

constexpr double kDeg = std::numbers::pi / 180.0;

// Decodes one packet as a partial scan and returns its points.
std::vector<PointXYZIRT> decode_one(DecoderConfig cfg, const PacketBuilder& b, Nanos stamp = 1'000'000'000) {
  cfg.emit_partial_scans = true;
  Decoder dec(cfg);
  const auto bytes = b.bytes();
  EXPECT_FALSE(dec.push(PacketView{bytes, 0, velodyne::kDataPort}, stamp));
  EXPECT_EQ(dec.last_status(), PacketStatus::kOk);
  auto scan = dec.flush();
  EXPECT_TRUE(scan.has_value());
  return scan ? scan->points : std::vector<PointXYZIRT>{};
}

DecoderConfig vlp16_no_offsets() {
  DecoderConfig cfg;
  cfg.model = Model::kVLP16;
  auto cal = velodyne::default_calibration(Model::kVLP16);
  for (auto& l : cal.lasers) l.vert_offset_correction = 0.0;
  cfg.calibration = cal;
  return cfg;
}

TEST(VelodyneGeometry, AzimuthsMapToRep103) {
  // Velodyne azimuth is clockwise from the front: 0° forward (+x), 90° right (-y), 270° left (+y).
  struct Dir {
    int az;
    double x, y;
  };
  for (const Dir d : {Dir{0, 1, 0}, Dir{9000, 0, -1}, Dir{18000, -1, 0}, Dir{27000, 0, 1}, Dir{4500, 0.7071, -0.7071}}) {
    PacketBuilder b;
    b.azimuths(d.az, 0).ret(0, 1, 5000, 77);  // laser 1: +1°, 10 m
    const auto pts = decode_one(vlp16_no_offsets(), b);
    ASSERT_EQ(pts.size(), 1U) << d.az;
    const double h = 10.0 * std::cos(1 * kDeg);
    EXPECT_NEAR(pts[0].x, d.x * h, 1e-3) << d.az;
    EXPECT_NEAR(pts[0].y, d.y * h, 1e-3) << d.az;
    EXPECT_NEAR(pts[0].z, 10.0 * std::sin(1 * kDeg), 1e-4);
    EXPECT_EQ(pts[0].intensity, 77.0F);
    EXPECT_EQ(pts[0].ring, 8);
    EXPECT_EQ(pts[0].return_type, kReturnStrongest);
  }
}

TEST(VelodyneGeometry, ElevationOffsetsAndRings) {
  PacketBuilder b;
  b.azimuths(0, 0);
  for (std::size_t c = 0; c < 16; ++c) b.ret(0, c, 2500, static_cast<std::uint8_t>(c));  // 5 m
  DecoderConfig cfg;  // built-in VLP-16 with the manual's vertical offsets
  cfg.model = Model::kVLP16;
  const auto pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 16U);
  const auto cal = velodyne::default_calibration(Model::kVLP16);
  for (std::size_t c = 0; c < 16; ++c) {
    const double v = cal.lasers[c].vert_correction;
    const double vo = cal.lasers[c].vert_offset_correction;
    EXPECT_NEAR(pts[c].x, 5.0 * std::cos(v) - vo * std::sin(v), 1e-4) << c;
    EXPECT_NEAR(pts[c].y, 0.0, 1e-5) << c;
    EXPECT_NEAR(pts[c].z, 5.0 * std::sin(v) + vo * std::cos(v), 1e-4) << c;
    // Ring = rank of the elevation: -15° -> 0, +1° -> 8, +15° -> 15.
    const int deg = static_cast<int>(std::lround(v / kDeg));
    EXPECT_EQ(pts[c].ring, (deg + 15) / 2) << c;
  }
}

TEST(VelodyneGeometry, Vlp32cRotationCorrection) {
  PacketBuilder b(ProductId::kVLP32C);
  b.azimuths(0, 0).ret(0, 0, 2500, 1).ret(0, 1, 2500, 1);  // 4 mm units: 10 m
  DecoderConfig cfg;
  cfg.model = Model::kVLP32C;
  const auto pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 2U);
  // Laser 0 sits 1.4° clockwise (azimuth offset +1.4°: to the right), laser 1 4.2° to the left.
  const double h0 = 10.0 * std::cos(-25 * kDeg);
  EXPECT_NEAR(pts[0].x, h0 * std::cos(1.4 * kDeg), 1e-3);
  EXPECT_NEAR(pts[0].y, -h0 * std::sin(1.4 * kDeg), 1e-3);
  const double h1 = 10.0 * std::cos(-1 * kDeg);
  EXPECT_NEAR(pts[1].y, h1 * std::sin(4.2 * kDeg), 1e-3);
}

TEST(VelodyneTiming, PerPointTimeFollowsFiringTables) {
  struct M {
    Model model;
    ProductId pid;
    double block_us;
  };
  for (const M m : {M{Model::kVLP16, ProductId::kVLP16, 110.592}, M{Model::kVLP32C, ProductId::kVLP32C, 55.296},
                    M{Model::kHDL32E, ProductId::kHDL32E, 46.08}}) {
    PacketBuilder b(m.pid);
    b.azimuths(1000, 20).all(1000, 5);
    DecoderConfig cfg;
    cfg.model = m.model;
    const auto pts = decode_one(cfg, b);
    ASSERT_EQ(pts.size(), 12U * 32U);
    for (std::size_t blk = 0; blk < 12; ++blk) {
      for (int c = 0; c < 32; ++c) {
        const auto expected = static_cast<std::uint32_t>(std::lround(static_cast<double>(blk) * m.block_us * 1000.0)) +
                              velodyne::channel_offset_ns(m.model, c);
        EXPECT_NEAR(pts[blk * 32 + static_cast<std::size_t>(c)].t, expected, 1.0) << blk << "/" << c;
      }
    }
  }
  EXPECT_EQ(velodyne::channel_offset_ns(Model::kVLP16, 20), 55296U + 4U * 2304U);
  EXPECT_EQ(velodyne::channel_offset_ns(Model::kVLP32C, 5), 2U * 2304U);
  EXPECT_EQ(velodyne::channel_offset_ns(Model::kHDL32E, 31), 35712U);
}

TEST(VelodyneTiming, Vlp16SecondSequenceIsInterpolated) {
  PacketBuilder b;
  b.azimuths(0, 40).ret(0, 0, 5000, 1).ret(0, 16, 5000, 1).ret(0, 31, 5000, 1);
  auto cfg = vlp16_no_offsets();
  cfg.interpolation = velodyne::AzimuthInterpolation::kPerSequence;  // VeloView's
  auto pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 3U);
  const auto az = [](const PointXYZIRT& p) { return -std::atan2(static_cast<double>(p.y), static_cast<double>(p.x)) / kDeg; };
  EXPECT_NEAR(az(pts[0]), 0.0, 1e-3);
  EXPECT_NEAR(az(pts[1]), 0.2, 1e-3);  // half of the 0.4° block step
  EXPECT_NEAR(az(pts[2]), 0.2, 1e-3);
  cfg.interpolation = velodyne::AzimuthInterpolation::kPerLaser;
  pts = decode_one(cfg, b);
  EXPECT_NEAR(az(pts[2]), 0.4 * (55.296 + 15 * 2.304) / 110.592, 0.006);
}

// Feeds packets of steadily rotating azimuth; returns the scans emitted.
std::vector<Scan> rotate(Decoder& dec, int start_az, int packets, int step = 40, Nanos t0 = 5'000'000'000) {
  std::vector<Scan> out;
  int az = start_az;
  Nanos t = t0;
  for (int k = 0; k < packets; ++k) {
    PacketBuilder b;
    b.azimuths(az, step).all(1000, 9);
    const auto bytes = b.bytes();
    if (auto s = dec.push(PacketView{bytes, t, velodyne::kDataPort}, t)) out.push_back(std::move(*s));
    az = (az + 12 * step) % 36000;
    t += 1'327'104;
  }
  return out;
}

TEST(VelodyneScans, CutAtWrapSkipsThePartialFirstScan) {
  Decoder dec(vlp16_no_offsets());
  // 75 packets of 4.8° = one revolution; start at 180° so the first wrap is mid-way.
  const auto scans = rotate(dec, 18000, 75 * 3);
  ASSERT_EQ(scans.size(), 2U);  // partial first dropped, two complete, the third is in progress
  for (std::size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(scans[i].seq, i);
    EXPECT_EQ(scans[i].points.size(), 75U * 12U * 32U);
    EXPECT_EQ(scans[i].packets, 76U);  // the wrap falls mid-packet: that packet counts for both scans
    // The first point of a complete scan is at azimuth 0 (forward).
    EXPECT_NEAR(scans[i].points.front().y, 0.0, 1e-3);
    EXPECT_GT(scans[i].points.front().x, 0.0F);
  }
  EXPECT_EQ(scans[1].stamp - scans[0].stamp, 75 * 1'327'104);
  EXPECT_EQ(dec.stats().partial_scans_discarded, 1U);
  const auto tail = dec.flush();
  ASSERT_TRUE(tail.has_value());
  EXPECT_EQ(tail->packets, 38U);
}

// The first scan's buffer holds the model's typical scan unless the config asks for less (the
// fuzz harness: a decoder per input); a smaller buffer grows to the same points.
TEST(VelodyneScans, FirstScanReserveFromTheConfig) {
  PacketBuilder b;
  b.azimuths(0, 40).all(1000, 9);
  const auto bytes = b.bytes();
  const auto first_scan = [&bytes](std::size_t reserve) {
    auto cfg = vlp16_no_offsets();
    cfg.emit_partial_scans = true;
    cfg.first_scan_reserve_points = reserve;
    Decoder dec(cfg);
    (void)dec.push(PacketView{bytes, 0, velodyne::kDataPort}, 1'000'000'000);
    auto s = dec.flush();
    EXPECT_TRUE(s.has_value());
    return s ? std::move(s->points) : std::vector<PointXYZIRT>{};
  };
  const auto typical = first_scan(0);
  const auto small = first_scan(64);
  const auto typical_points = static_cast<std::size_t>(velodyne::model_info(Model::kVLP16).typical_points_per_scan);
  EXPECT_GE(typical.capacity(), typical_points);
  EXPECT_LT(small.capacity(), typical_points);
  ASSERT_EQ(small.size(), 12U * 32U);
  ASSERT_EQ(small.size(), typical.size());
  EXPECT_EQ(std::memcmp(small.data(), typical.data(), small.size() * sizeof(PointXYZIRT)), 0);
}

TEST(VelodyneScans, CutAngleMidPacket) {
  auto cfg = vlp16_no_offsets();
  cfg.cut_angle_deg = 90.0;
  Decoder dec(cfg);
  const auto scans = rotate(dec, 100, 75 * 2 + 10, 40, 7'000'000'000);
  ASSERT_GE(scans.size(), 1U);
  const auto& s = scans[0];
  // The first block at or after 90.00°: azimuth 9000 exactly is block 5 of the packet at 86.5°...
  const auto& p = s.points.front();
  EXPECT_NEAR(-std::atan2(static_cast<double>(p.y), static_cast<double>(p.x)) / kDeg, 90.0, 0.21);
  EXPECT_EQ(s.points.size(), 75U * 12U * 32U);
  // Scan stamp = the first firing of the cut block; the first point has t = 0.
  EXPECT_EQ(p.t, 0U);
  EXPECT_EQ(s.packets, 76U);  // the packets on both sides of the cut count for both scans
}

TEST(VelodyneScans, Azimuth36000EndsTheRevolution) {
  // Real sensors report 360.00° at the wrap: it is 0° for geometry, and the scan cut comes after it.
  PacketBuilder b;
  b.azimuths(35840, 40);  // ..., 35960, 36000 (block 4), 40, ...
  b.azimuth(4, 36000).all(1000, 3);
  for (std::size_t k = 5; k < 12; ++k) b.azimuth(k, static_cast<int>(k - 4) * 40);
  auto cfg = vlp16_no_offsets();
  cfg.emit_partial_scans = true;
  Decoder dec(cfg);
  const auto bytes = b.bytes();
  const auto first = dec.push(PacketView{bytes, 0, 2368}, 1'000'000'000);
  EXPECT_EQ(dec.last_status(), PacketStatus::kOk);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->points.size(), 5U * 32U);
  const auto& p = first->points[4 * 32];  // block 4, laser 0
  EXPECT_NEAR(p.y, 0.0, 1e-4);
  EXPECT_GT(p.x, 0.0F);
}

TEST(VelodyneScans, BadCutAngleOrRangeThrows) {
  auto cfg = vlp16_no_offsets();
  cfg.cut_angle_deg = 360.0;
  EXPECT_THROW(Decoder{cfg}, std::invalid_argument);
  cfg.cut_angle_deg = 0;
  cfg.min_range_m = 5;
  cfg.max_range_m = 1;
  EXPECT_THROW(Decoder{cfg}, std::invalid_argument);
}

TEST(VelodyneScans, TimeJumpEndsTheScan) {
  Decoder dec(vlp16_no_offsets());
  rotate(dec, 0, 10, 40, 9'000'000'000);
  // Sensor clock reset: the next packet is an hour back.
  auto after = rotate(dec, 4800, 10, 40, 9'000'000'000 - 3'600'000'000'000);
  EXPECT_EQ(dec.stats().time_jumps, 1U);
  EXPECT_TRUE(after.empty());  // the interrupted scan is partial: not emitted by default
  // The first packet of the step is judged alone (a corrupt time: dropped, counted); the second
  // confirms the step (issue 26 item 2).
  EXPECT_EQ(dec.stats().by_status[static_cast<std::size_t>(PacketStatus::kBadTime)], 1U);
  const auto tail = dec.flush();
  ASSERT_TRUE(tail);
  EXPECT_EQ(tail->packets, 9U);
  EXPECT_GE(tail->dropped, 1U);
  for (const auto& p : tail->points) EXPECT_LT(p.t, 20'000'000U);
}

TEST(VelodyneReturns, RangeLimits) {
  PacketBuilder b;
  b.azimuths(0, 0).ret(0, 0, 100, 1).ret(0, 1, 1000, 1).ret(0, 2, 30000, 1).ret(0, 3, 0, 1);  // 0.2, 2, 60 m, none
  auto cfg = vlp16_no_offsets();
  EXPECT_EQ(decode_one(cfg, b).size(), 3U);
  cfg.min_range_m = 0.5;
  cfg.max_range_m = 50;
  const auto pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 1U);
  EXPECT_NEAR(std::hypot(pts[0].x, pts[0].y, pts[0].z), 2.0, 1e-4);
}

TEST(VelodyneReturns, DualReturnPairs) {
  PacketBuilder b(ProductId::kVLP16, ReturnMode::kDual);
  b.azimuths(0, 40, true);
  b.ret(0, 0, 1000, 50).ret(1, 0, 1000, 50);  // one echo reported twice
  b.ret(0, 1, 2000, 10).ret(1, 1, 1500, 90);  // last weak, strongest earlier
  b.ret(0, 2, 2000, 90).ret(1, 2, 1500, 10);  // last is strongest; odd block = second strongest
  auto cfg = vlp16_no_offsets();
  cfg.returns = ReturnSelection::kDual;
  auto pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 5U);
  EXPECT_EQ(pts[0].return_type, kReturnStrongestAndLast);
  EXPECT_EQ(pts[1].return_type, kReturnLast);
  EXPECT_EQ(pts[2].return_type, kReturnStrongest);
  EXPECT_EQ(pts[2].intensity, 90.0F);
  EXPECT_EQ(pts[3].return_type, kReturnStrongestAndLast);
  EXPECT_EQ(pts[4].return_type, kReturnSecondStrongest);
  EXPECT_EQ(pts[1].t, pts[2].t);  // both echoes of one firing

  cfg.returns = ReturnSelection::kStrongest;
  pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 3U);
  EXPECT_EQ(pts[1].intensity, 90.0F);
  EXPECT_EQ(pts[2].intensity, 90.0F);
  cfg.returns = ReturnSelection::kLast;
  pts = decode_one(cfg, b);
  ASSERT_EQ(pts.size(), 3U);
  EXPECT_EQ(pts[1].intensity, 10.0F);
  EXPECT_EQ(pts[1].return_type, kReturnLast);
  // Dual pairs share a firing period: block 2 starts one 110.592 µs period in.
  PacketBuilder b2(ProductId::kVLP16, ReturnMode::kDual);
  b2.azimuths(0, 40, true).ret(2, 0, 1000, 1);
  cfg.returns = ReturnSelection::kDual;
  pts = decode_one(cfg, b2);
  ASSERT_EQ(pts.size(), 1U);
  EXPECT_EQ(pts[0].t, 110592U);  // the scan stamp is block 0's firing, not the first point's
}

TEST(VelodyneDrops, BadPacketsAreCountedNotDecoded) {
  Decoder dec(vlp16_no_offsets());
  PacketBuilder good;
  good.azimuths(100, 40).all(1000, 1);
  std::vector<std::pair<std::vector<std::byte>, PacketStatus>> cases;
  const auto g = good.bytes();
  cases.push_back({std::vector<std::byte>(g.begin(), g.begin() + 1000), PacketStatus::kWrongSize});
  cases.push_back({std::vector<std::byte>(512), PacketStatus::kNotData});
  cases.push_back({std::vector<std::byte>(1206, std::byte{0xAB}), PacketStatus::kBadBlockFlag});
  PacketBuilder bad_az = good;
  bad_az.azimuth(7, 36001);
  const auto ba = bad_az.bytes();
  cases.push_back({std::vector<std::byte>(ba.begin(), ba.end()), PacketStatus::kBadAzimuth});
  PacketBuilder other(ProductId::kVLP32C);
  other.azimuths(100, 40);
  const auto ob = other.bytes();
  cases.push_back({std::vector<std::byte>(ob.begin(), ob.end()), PacketStatus::kWrongModel});
  PacketBuilder bad_mode = good;
  bad_mode.raw().return_mode = 0x55;
  const auto bm = bad_mode.bytes();
  cases.push_back({std::vector<std::byte>(bm.begin(), bm.end()), PacketStatus::kWrongModel});
  for (const auto& [bytes, status] : cases) {
    EXPECT_FALSE(dec.push(PacketView{bytes, 0, 2368}, 1'000'000'000));
    EXPECT_EQ(dec.last_status(), status) << to_string(status);
    EXPECT_EQ(velodyne::check_packet(bytes, Model::kVLP16), status);
  }
  EXPECT_FALSE(dec.push(PacketView{g, 0, 2368}, 1'000'000'000));
  EXPECT_EQ(dec.last_status(), PacketStatus::kOk);
  const auto& st = dec.stats();
  EXPECT_EQ(st.packets, cases.size() + 1);
  EXPECT_EQ(st.dropped(), cases.size());
  EXPECT_EQ(st.by_status[static_cast<std::size_t>(PacketStatus::kWrongModel)], 2U);
  const auto scan = dec.flush();
  ASSERT_TRUE(scan);
  EXPECT_EQ(scan->dropped, cases.size());
  EXPECT_EQ(scan->packets, 1U);
  EXPECT_STREQ(to_string(PacketStatus::kBadAzimuth), "bad_azimuth");
}

TEST(VelodynePacketInfo, TrailerAndHourMapping) {
  PacketBuilder b(ProductId::kHDL32E, ReturnMode::kLast);
  b.azimuths(1234, 20).timestamp(3'599'000'000U);
  const auto bytes = b.bytes();
  const auto info = velodyne::read_packet_info(bytes);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->sensor_time_us, 3'599'000'000U);
  EXPECT_EQ(info->return_mode, 0x38);
  EXPECT_EQ(info->product_id, 0x21);
  EXPECT_EQ(info->first_azimuth, 1234);
  EXPECT_FALSE(info->dual());
  EXPECT_FALSE(velodyne::read_packet_info(std::span(bytes).first(100)));
  // 59:59 of the previous hour, referenced 2 s after the hour boundary.
  constexpr Nanos kHour = 3'600'000'000'000;
  const Nanos ref = 10 * kHour + 2'000'000'000;
  EXPECT_EQ(velodyne::sensor_time_to_ns(3'599'000'000U, ref), 10 * kHour - 1'000'000'000);
  EXPECT_EQ(velodyne::sensor_time_to_ns(5'000'000U, ref), 10 * kHour + 5'000'000'000);
  EXPECT_EQ(velodyne::sensor_time_to_ns(1'000U, 11 * kHour - 1'000'000), 11 * kHour + 1'000'000);
}

}  // namespace
}  // namespace sensor_rig::lidar::test
