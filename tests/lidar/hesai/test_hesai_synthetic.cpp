// Hesai decoder on packets built here: geometry (known distance/azimuth -> xyz in REP 103), ring,
// intensity, per-point time, packet time, echo selection, scan cut, drops, time jumps.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sensor_rig/lidar/hesai/packet.hpp"
#include "sensor_rig/lidar/hesai/scan_decoder.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::hesai::test {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

DecoderConfig config(Model m, ReturnSelection r = ReturnSelection::kStrongest) {
  DecoderConfig c;
  c.model = m;
  c.returns = r;
  return c;
}

void expect_point(const PointXYZIRT& p, double d, double az_deg, double el_deg) {
  EXPECT_NEAR(p.x, d * std::cos(el_deg * kDeg) * std::cos(az_deg * kDeg), 1e-4);
  EXPECT_NEAR(p.y, -d * std::cos(el_deg * kDeg) * std::sin(az_deg * kDeg), 1e-4);
  EXPECT_NEAR(p.z, d * std::sin(el_deg * kDeg), 1e-4);
}

TEST(HesaiGeometry, Pandar40PKnownPoints) {
  PacketSpec s;
  s.azimuth0 = 9000;  // 90°: the sensor's right
  s.unit = [](int b, int c) -> RawUnit {
    if (b == 0 && c == 11) return {2500, 77};  // channel 12: elevation 0°, azimuth offset -1.042°
    if (b == 3 && c == 0) return {500, 9};     // channel 1: 15°, group 3 (azimuth 90.6°)
    return {};
  };
  const auto pts = decode_one(config(Model::kPandar40P), build_packet(s));
  ASSERT_EQ(pts.size(), 2U);
  expect_point(pts[0], 10.0, 90.0 - 1.042, 0.0);
  EXPECT_LT(pts[0].y, -9.9F) << "azimuth is clockwise: 90° is to the right (-y in REP 103)";
  EXPECT_EQ(pts[0].intensity, 77.0F);
  EXPECT_EQ(pts[0].ring, 28) << "28 channels are below 0°";
  EXPECT_EQ(pts[0].return_type, kReturnStrongest);
  EXPECT_EQ(pts[0].t, 46'480U) << "channel 12 fires -8.19 µs, the first channel -54.67 µs";
  expect_point(pts[1], 2.0, 90.6 - 1.042, 15.0);
  EXPECT_EQ(pts[1].ring, 39);
  EXPECT_EQ(pts[1].t, 3U * 55'560U + 12'450U);
}

TEST(HesaiGeometry, PandarXT32KnownPointsAndDistanceUnit) {
  PacketSpec s;
  s.kind = Kind::kXT32;
  s.azimuth0 = 18000;
  s.unit = [](int b, int c) -> RawUnit {
    if (b == 1 && c == 0) return {1000, 200};  // channel 1: 15°, azimuth 180.2°
    if (b == 0 && c == 31) return {250, 1};    // channel 32: -16°
    if (b == 2 && c == 15) return {100, 5};    // channel 16: 0°
    return {};
  };
  const auto pts = decode_one(config(Model::kPandarXT32), build_packet(s));
  ASSERT_EQ(pts.size(), 3U);
  // Packet order: per azimuth group, per channel.
  expect_point(pts[0], 1.0, 180.0, -16.0);
  EXPECT_EQ(pts[0].ring, 0);
  EXPECT_EQ(pts[0].t, 31U * 1512U);
  expect_point(pts[1], 4.0, 180.2, 15.0);
  EXPECT_EQ(pts[1].ring, 31);
  EXPECT_EQ(pts[1].t, 50'000U);
  EXPECT_EQ(pts[1].intensity, 200.0F);
  expect_point(pts[2], 0.4, 180.4, 0.0);
  s.dis_unit = 2;  // the header's distance unit is honoured
  const auto half = decode_one(config(Model::kPandarXT32), build_packet(s));
  ASSERT_EQ(half.size(), 3U);
  expect_point(half[1], 2.0, 180.2, 15.0);
}

TEST(HesaiGeometry, RangeLimits) {
  PacketSpec s;
  s.azimuth0 = 9000;
  s.unit = [](int, int c) -> RawUnit { return {static_cast<std::uint16_t>(25 * (c + 1)), 1}; };  // 0.1 .. 4 m
  auto cfg = config(Model::kPandar40P);
  cfg.min_range_m = 1.0;
  cfg.max_range_m = 2.0;
  const auto pts = decode_one(cfg, build_packet(s));
  EXPECT_EQ(pts.size(), 10U * 11U) << "channels 10..20 (1.0 .. 2.0 m) in 10 groups";
  for (const auto& p : pts) {
    const double r = static_cast<double>(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z));
    EXPECT_GE(r, 1.0 - 1e-5);
    EXPECT_LE(r, 2.0 + 1e-5);
  }
  EXPECT_THAT(error_of([] {
                DecoderConfig c;
                c.min_range_m = 5;
                c.max_range_m = 1;
                Decoder d(c);
              }),
              ::testing::HasSubstr("range"));
  EXPECT_THAT(error_of([] {
                DecoderConfig c;
                c.cut_angle_deg = 360;
                Decoder d(c);
              }),
              ::testing::HasSubstr("cut angle"));
}

TEST(HesaiTime, PacketTimeIsTheFirstFiringInUtc) {
  constexpr Nanos kTail = 1'673'398'923LL * 1'000'000'000 + 500'000'000;  // 2023-01-11 01:02:03.5 UTC
  struct Case {
    const char* model;
    Kind kind;
    std::uint8_t mode;
    Nanos first_offset;
  };
  for (const auto& c : {Case{"Pandar40P", Kind::k40P, 0x37, -28'580 - 9 * 55'560 - 54'670},
                        Case{"Pandar40P", Kind::k40P, 0x39, -28'580 - 4 * 55'560 - 54'670},
                        Case{"PandarXT32", Kind::kXT32, 0x38, -7 * 50'000 + 6'000},
                        Case{"PandarXT32", Kind::kXT32, 0x3B, -3 * 50'000 + 6'000}}) {
    SCOPED_TRACE(std::string(c.model) + " mode " + std::to_string(c.mode));
    DecoderOptions o;
    o.model = c.model;
    const auto dec = make_decoder(o);
    PacketSpec s;
    s.kind = c.kind;
    s.return_mode = c.mode;
    s.us = 500'000;
    const auto pkt = build_packet(s);
    const auto t = dec->packet_time(pkt);
    ASSERT_EQ(t.kind, SensorTime::Kind::kAbsoluteNs);
    EXPECT_EQ(t.value, kTail + c.first_offset);
    (void)dec->push(PacketView{pkt, kTail, kDataPort}, t.value);
    EXPECT_EQ(dec->packet_span_ns(), -c.first_offset) << "span follows the packets' return mode";
    s.utc[1] = 13;  // month 13: no usable time
    EXPECT_EQ(dec->packet_time(build_packet(s)).kind, SensorTime::Kind::kNone);
  }
}

// One packet, echoes of channel 12/13/14 (indices 11..13) in the first azimuth group.
std::vector<PointXYZIRT> dual_40p(ReturnSelection r) {
  PacketSpec s;
  s.return_mode = 0x39;  // block 2n = last, 2n+1 = strongest
  s.azimuth0 = 9000;
  s.unit = [](int b, int c) -> RawUnit {
    if (b > 1) return {};
    if (c == 11) return b == 0 ? RawUnit{2500, 50} : RawUnit{1250, 100};  // strongest is not the last
    if (c == 12) return {2000, 80};                                       // one echo, sent twice
    if (c == 13) return b == 0 ? RawUnit{3000, 90} : RawUnit{3010, 20};   // 4 cm apart
    return {};
  };
  return decode_one(config(Model::kPandar40P, r), build_packet(s));
}

double range(const PointXYZIRT& p) { return static_cast<double>(std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z)); }

TEST(HesaiReturns, Pandar40PDualLastStrongest) {
  const auto dual = dual_40p(ReturnSelection::kDual);
  ASSERT_EQ(dual.size(), 4U);
  EXPECT_NEAR(range(dual[0]), 10.0, 1e-4);
  EXPECT_EQ(dual[0].return_type, kReturnLast);
  EXPECT_NEAR(range(dual[1]), 5.0, 1e-4);
  EXPECT_EQ(dual[1].return_type, kReturnStrongest);
  EXPECT_NEAR(range(dual[2]), 8.0, 1e-4);
  EXPECT_EQ(dual[2].return_type, kReturnStrongestAndLast) << "identical echoes are kept once";
  EXPECT_NEAR(range(dual[3]), 12.04, 1e-4) << "echoes closer than 0.1 m: the second block's is kept";
  EXPECT_EQ(dual[3].return_type, kReturnSecondStrongest);

  const auto strongest = dual_40p(ReturnSelection::kStrongest);
  ASSERT_EQ(strongest.size(), 3U);
  EXPECT_NEAR(range(strongest[0]), 5.0, 1e-4);
  EXPECT_EQ(strongest[0].return_type, kReturnStrongest);
  EXPECT_EQ(strongest[1].return_type, kReturnStrongestAndLast);
  EXPECT_NEAR(range(strongest[2]), 12.0, 1e-4);
  EXPECT_EQ(strongest[2].return_type, kReturnStrongestAndLast);

  const auto last = dual_40p(ReturnSelection::kLast);
  ASSERT_EQ(last.size(), 3U);
  EXPECT_NEAR(range(last[0]), 10.0, 1e-4);
  EXPECT_EQ(last[0].return_type, kReturnLast);
  EXPECT_NEAR(range(last[2]), 12.0, 1e-4);
  EXPECT_EQ(dual[0].t, dual[1].t) << "both echoes of a firing share its time";
  EXPECT_EQ(dual[0].t, 46'480U);
}

TEST(HesaiReturns, PandarXT32DualModes) {
  PacketSpec s;
  s.kind = Kind::kXT32;
  s.azimuth0 = 9000;
  s.return_mode = 0x3B;  // first + last; the XT32 sends the last echo in the first block
  s.unit = [](int b, int c) -> RawUnit {
    if (c != 0 || b > 1) return {};
    return b == 0 ? RawUnit{2000, 10} : RawUnit{1000, 60};
  };
  const auto dual = decode_one(config(Model::kPandarXT32, ReturnSelection::kDual), build_packet(s));
  ASSERT_EQ(dual.size(), 2U);
  EXPECT_NEAR(range(dual[0]), 8.0, 1e-4);
  EXPECT_EQ(dual[0].return_type, kReturnLast);
  EXPECT_EQ(dual[1].return_type, kReturnFirst);
  const auto last = decode_one(config(Model::kPandarXT32, ReturnSelection::kLast), build_packet(s));
  ASSERT_EQ(last.size(), 1U);
  EXPECT_NEAR(range(last[0]), 8.0, 1e-4);
  const auto strongest = decode_one(config(Model::kPandarXT32, ReturnSelection::kStrongest), build_packet(s));
  ASSERT_EQ(strongest.size(), 1U);
  EXPECT_NEAR(range(strongest[0]), 4.0, 1e-4) << "the brighter echo";

  s.return_mode = 0x3C;  // first + strongest
  const auto fs = decode_one(config(Model::kPandarXT32, ReturnSelection::kDual), build_packet(s));
  ASSERT_EQ(fs.size(), 2U);
  EXPECT_EQ(fs[0].return_type, kReturnFirst);
  EXPECT_EQ(fs[1].return_type, kReturnStrongest);
  // Dual packets carry 4 azimuth groups of 50 µs.
  EXPECT_EQ(dual[0].t, 0U);
}

TEST(HesaiReturns, SingleReturnPacketsKeepTheirEcho) {
  PacketSpec s;
  s.azimuth0 = 9000;
  s.return_mode = 0x38;
  s.unit = [](int b, int c) -> RawUnit { return b == 0 && c == 0 ? RawUnit{1000, 3} : RawUnit{}; };
  for (auto r : {ReturnSelection::kStrongest, ReturnSelection::kLast, ReturnSelection::kDual}) {
    const auto pts = decode_one(config(Model::kPandar40P, r), build_packet(s));
    ASSERT_EQ(pts.size(), 1U);
    EXPECT_EQ(pts[0].return_type, kReturnLast);
  }
}

}  // namespace
}  // namespace sensor_rig::lidar::hesai::test
