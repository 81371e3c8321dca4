// Hesai scan assembly on synthetic rotations: scan cut by corrected azimuth, partial scans,
// stamps, drops of truncated/garbage packets, time jumps.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>

#include "sensor_rig/lidar/hesai/packet.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::hesai::test {
namespace {

constexpr Nanos kT0 = 1'700'000'000'000'000'000LL;
constexpr Nanos k40PPacketNs = 10 * 55'560;  // single return: 10 groups

// Azimuth of a point in the sensor's convention (clockwise from the front), degrees in [0, 360).
double azimuth_deg(const PointXYZIRT& p) {
  const double a = std::atan2(-static_cast<double>(p.y), static_cast<double>(p.x)) * 180.0 / std::numbers::pi;
  return a < 0 ? a + 360.0 : a;
}

// `packets` single-return Pandar40P packets of a 10 Hz rotation starting at azimuth0 (0.01°).
std::vector<Scan> rotate(DecoderConfig cfg, int packets, int azimuth0 = 4000) {
  Decoder d(std::move(cfg));
  std::vector<Scan> scans;
  for (int k = 0; k < packets; ++k) {
    PacketSpec s;
    s.azimuth0 = (azimuth0 + 200 * k) % kAzimuthCount;
    s.unit = [](int, int c) -> RawUnit { return {2500, static_cast<std::uint8_t>(c)}; };
    const auto pkt = build_packet(s);
    const Nanos t = kT0 + k * k40PPacketNs;
    if (auto scan = d.push(PacketView{pkt, t + 600'000, kDataPort}, t)) scans.push_back(std::move(*scan));
  }
  EXPECT_EQ(d.stats().dropped(), 0U);
  return scans;
}

class HesaiScanCut : public ::testing::TestWithParam<double> {};

TEST_P(HesaiScanCut, ScanHoldsOneTurnOfCorrectedAzimuthFromTheCut) {
  const double cut = GetParam();
  DecoderConfig cfg;
  cfg.cut_angle_deg = cut;
  const auto scans = rotate(cfg, 600);  // azimuth 40° .. 1240°
  // A scan ends once every channel has passed the cut (the 40P's offsets reach -5.21°); the scan
  // before the first cut is partial and not emitted.
  std::size_t cuts = 0;
  for (double c = cut; c + 5.21 <= 1240.0; c += 360.0) cuts += c > 40.0 ? 1 : 0;
  ASSERT_EQ(scans.size(), cuts - 1);
  for (const auto& s : scans) {
    SCOPED_TRACE("scan " + std::to_string(s.seq));
    EXPECT_EQ(s.points.size(), 1800U * 40U) << "every firing of one turn, once";
    double lo = 360, hi = 0;
    for (const auto& p : s.points) {
      double rel = azimuth_deg(p) - cut;
      if (rel < 0) rel += 360.0;
      if (rel > 359.9999) rel -= 360.0;  // float rounding just below the cut
      lo = std::min(lo, rel);
      hi = std::max(hi, rel);
    }
    EXPECT_GE(lo, -1e-3);
    EXPECT_LT(lo, 0.2 + 1e-3);
    EXPECT_GT(hi, 359.8 - 1e-3);
    EXPECT_EQ(s.dropped, 0U);
    // t: ns after the scan's first firing; one turn is 1800 groups of 55.56 µs, plus the window
    // around the cut where channels straddle it (-3.13° .. +5.21°: 42 groups).
    std::uint32_t tmax = 0;
    for (const auto& p : s.points) tmax = std::max(tmax, p.t);
    EXPECT_GT(tmax, 1800U * 55'560U);
    EXPECT_LT(tmax, (1800U + 43U) * 55'560U);
  }
  EXPECT_EQ(scans[1].stamp - scans[0].stamp, 1800LL * 55'560) << "exactly one turn apart";
  EXPECT_EQ(scans[0].seq, 0U);
  EXPECT_EQ(scans[1].seq, 1U);
}

INSTANTIATE_TEST_SUITE_P(CutAngles, HesaiScanCut, ::testing::Values(0.0, 90.0, 123.45, 359.0));

TEST(HesaiScans, PartialScansOnRequest) {
  DecoderConfig cfg;
  cfg.emit_partial_scans = true;
  const auto scans = rotate(cfg, 600);
  ASSERT_EQ(scans.size(), 3U);
  EXPECT_LT(scans[0].points.size(), 1800U * 40U);
  EXPECT_EQ(scans[1].points.size(), 1800U * 40U);
}

// Both scan buffers (current and lookahead) hold the model's typical scan unless the config asks
// for less (the fuzz harness: a decoder per input); a smaller buffer grows to the same points.
TEST(HesaiScans, FirstScanReserveFromTheConfig) {
  PacketSpec spec;
  spec.azimuth0 = 4000;
  spec.unit = [](int, int c) -> RawUnit { return {2500, static_cast<std::uint8_t>(c)}; };
  const auto pkt = build_packet(spec);
  const auto first_scan = [&pkt](std::size_t reserve) {
    DecoderConfig cfg;
    cfg.emit_partial_scans = true;
    cfg.first_scan_reserve_points = reserve;
    Decoder d(cfg);
    (void)d.push(PacketView{pkt, kT0, kDataPort}, kT0);
    auto s = d.flush();
    EXPECT_TRUE(s.has_value());
    return s ? std::move(s->points) : std::vector<PointXYZIRT>{};
  };
  const auto typical = first_scan(0);
  const auto small = first_scan(64);
  const auto typical_points = static_cast<std::size_t>(model_info(Model::kPandar40P).typical_points_per_scan);
  EXPECT_GE(typical.capacity(), typical_points);
  EXPECT_LT(small.capacity(), typical_points);
  ASSERT_EQ(small.size(), 10U * 40U);
  ASSERT_EQ(small.size(), typical.size());
  EXPECT_EQ(std::memcmp(small.data(), typical.data(), small.size() * sizeof(PointXYZIRT)), 0);
}

TEST(HesaiScans, XT32DualRotation) {
  DecoderConfig cfg;
  cfg.model = Model::kPandarXT32;
  cfg.returns = ReturnSelection::kDual;
  Decoder d(cfg);
  std::vector<Scan> scans;
  // Dual: 4 azimuth groups per packet, 0.18° apart (2000 groups per turn at 10 Hz).
  for (int k = 0; k < 1500; ++k) {
    PacketSpec s;
    s.kind = Kind::kXT32;
    s.return_mode = 0x39;
    s.step = 18;
    s.azimuth0 = (5000 + 72 * k) % kAzimuthCount;
    s.unit = [](int b, int) -> RawUnit { return b % 2 == 0 ? RawUnit{2500, 10} : RawUnit{1250, 90}; };
    const auto pkt = build_packet(s);
    const Nanos t = kT0 + k * 200'000LL;
    if (auto scan = d.push(PacketView{pkt, t, kDataPort}, t)) scans.push_back(std::move(*scan));
  }
  ASSERT_EQ(scans.size(), 2U);
  for (const auto& s : scans) EXPECT_EQ(s.points.size(), 2000U * 32U * 2U);
  EXPECT_EQ(scans[1].stamp - scans[0].stamp, 2000LL * 50'000);
}

TEST(HesaiScans, BlocksOnTheCutAngle) {
  // XT32 without azimuth offsets: the window around the cut is the cut itself, and blocks land on
  // it exactly (0.18° steps). Starting on the cut: the first scan is complete from the next turn.
  DecoderConfig cfg;
  cfg.model = Model::kPandarXT32;
  Decoder d(cfg);
  std::vector<Scan> scans;
  for (int k = 0; k < 1000; ++k) {
    PacketSpec s;
    s.kind = Kind::kXT32;
    s.step = 18;
    s.azimuth0 = (k * 8 * 18) % kAzimuthCount;
    s.unit = [](int, int) -> RawUnit { return {1000, 1}; };
    const auto pkt = build_packet(s);
    const Nanos t = kT0 + k * 400'000LL;
    if (auto scan = d.push(PacketView{pkt, t, kDataPort}, t)) scans.push_back(std::move(*scan));
  }
  ASSERT_EQ(scans.size(), 2U);
  for (const auto& s : scans) {
    EXPECT_EQ(s.points.size(), 2000U * 32U);
    for (const auto& p : s.points) ASSERT_LT(azimuth_deg(p), 359.82 + 1e-3);
  }
  EXPECT_EQ(d.stats().partial_scans_discarded, 1U);
}

TEST(HesaiDrops, TruncatedAndGarbagePacketsAreCounted) {
  Decoder d40(DecoderConfig{});
  PacketSpec s;
  s.azimuth0 = 9000;
  s.unit = [](int, int) -> RawUnit { return {1000, 1}; };
  const auto good = build_packet(s);
  auto push = [&](Decoder& d, const std::vector<std::byte>& p) {
    (void)d.push(PacketView{p, kT0, kDataPort}, kT0);
    return d.last_status();
  };
  auto truncated = good;
  truncated.resize(1000);
  EXPECT_EQ(push(d40, truncated), PacketStatus::kWrongSize);
  EXPECT_EQ(push(d40, std::vector<std::byte>(kGpsPacketSize)), PacketStatus::kNotData);
  auto bad_sob = good;
  bad_sob[124] = std::byte{0x00};  // block 1's start-of-block mark
  EXPECT_EQ(push(d40, bad_sob), PacketStatus::kBadBlockFlag);
  auto bad_az = good;
  put_le16(reinterpret_cast<std::uint8_t*>(bad_az.data()) + 2, 36000);
  EXPECT_EQ(push(d40, bad_az), PacketStatus::kBadAzimuth);
  auto bad_mode = good;
  bad_mode[offsetof(Packet40P, tail) + offsetof(Tail40P, return_mode)] = std::byte{0x00};
  EXPECT_EQ(push(d40, bad_mode), PacketStatus::kWrongModel);
  std::mt19937 rng(7);
  std::vector<std::byte> garbage(k40PPacketSize);
  for (auto& b : garbage) b = static_cast<std::byte>(rng());
  EXPECT_NE(push(d40, garbage), PacketStatus::kOk);
  PacketSpec xs;
  xs.kind = Kind::kXT32;
  EXPECT_EQ(push(d40, build_packet(xs)), PacketStatus::kWrongSize) << "an XT32 packet is not a 40P packet";
  auto with_seq = s;
  with_seq.with_sequence = true;
  EXPECT_EQ(push(d40, build_packet(with_seq)), PacketStatus::kOk) << "1266 bytes: with the UDP sequence";
  // The same azimuths again (and the same time): a duplicate, counted and not decoded twice.
  EXPECT_EQ(push(d40, good), PacketStatus::kOutOfOrder);
  const auto& st = d40.stats();
  EXPECT_EQ(st.packets, 9U);
  EXPECT_EQ(st.packets_used, 1U);
  EXPECT_EQ(st.dropped(), 8U);
  EXPECT_EQ(st.by_status[static_cast<std::size_t>(PacketStatus::kWrongSize)], 2U);
  EXPECT_EQ(st.by_status[static_cast<std::size_t>(PacketStatus::kOutOfOrder)], 1U);
  const auto scan = d40.flush();
  ASSERT_TRUE(scan);
  EXPECT_EQ(scan->dropped, 8U);
  EXPECT_EQ(scan->packets, 1U);

  DecoderConfig xc;
  xc.model = Model::kPandarXT32;
  Decoder dxt(xc);
  const auto xgood = build_packet(xs);
  auto lasers16 = xgood;
  lasers16[offsetof(HeaderXT, laser_num)] = std::byte{16};
  EXPECT_EQ(push(dxt, lasers16), PacketStatus::kWrongModel) << "an XT16 packet";
  auto bad_sop = xgood;
  bad_sop[0] = std::byte{0x12};
  EXPECT_EQ(push(dxt, bad_sop), PacketStatus::kBadBlockFlag);
  auto no_unit = xgood;
  no_unit[offsetof(HeaderXT, dis_unit)] = std::byte{0};
  EXPECT_EQ(push(dxt, no_unit), PacketStatus::kWrongModel);
  EXPECT_EQ(push(dxt, good), PacketStatus::kWrongSize);
  EXPECT_EQ(push(dxt, xgood), PacketStatus::kOk);
  EXPECT_EQ(dxt.stats().dropped(), 4U);
}

// The same packet again (its own azimuths and time unchanged) is a duplicate however late the
// host's stamp says it came: order is judged before the time (issue 26 item 1). A real clock step
// (a sustained one) still ends the scan: tests/lidar/scan/test_scan_faults.cpp.
TEST(HesaiScans, RepeatedPacketIsADuplicateNotATimeJump) {
  DecoderConfig cfg;
  cfg.emit_partial_scans = true;
  Decoder d(cfg);
  PacketSpec s;
  s.azimuth0 = 9000;
  s.unit = [](int, int) -> RawUnit { return {1000, 1}; };
  const auto pkt = build_packet(s);
  EXPECT_FALSE(d.push(PacketView{pkt, kT0, kDataPort}, kT0));
  EXPECT_FALSE(d.push(PacketView{pkt, kT0, kDataPort}, kT0 + 5'000'000'000LL));
  EXPECT_EQ(d.stats().time_jumps, 0U);
  EXPECT_EQ(d.stats().by_status[static_cast<std::size_t>(PacketStatus::kOutOfOrder)], 1U);
  const auto scan = d.flush();
  ASSERT_TRUE(scan);
  EXPECT_EQ(scan->points.size(), 400U);
  EXPECT_EQ(scan->dropped, 1U);
}

}  // namespace
}  // namespace sensor_rig::lidar::hesai::test
