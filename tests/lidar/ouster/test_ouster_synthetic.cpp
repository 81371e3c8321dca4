// Ouster decoder on synthetic packets of every profile: known ranges -> known points, return
// selection, scan assembly by frame id, invalid columns, and bad packets counted, never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>

#include "ouster_test_support.hpp"
#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/ouster/packet.hpp"
#include "sensor_rig/lidar/ouster/scan_decoder.hpp"

namespace sensor_rig::lidar::ouster::test {
namespace {

constexpr std::size_t kPixels = 16;
constexpr std::uint64_t kT0 = 1'700'000'000'000'000'000ULL;
constexpr double kPeriod = 1e9 / 10240.0;  // 1024x10

std::span<const std::byte> as_bytes(const std::vector<std::uint8_t>& v) { return std::as_bytes(std::span(v)); }

// The value every synthetic pixel carries (range a multiple of 8 mm for the 15-bit profiles).
Pixel pixel_at(std::size_t mid, std::size_t row) {
  Pixel p;
  p.first.range_mm = static_cast<std::uint32_t>(8 * (500 + 3 * row + mid % 11));
  p.first.reflectivity = static_cast<std::uint8_t>(row + 10);
  p.first.signal = static_cast<std::uint16_t>(200 + row);
  p.second.range_mm = p.first.range_mm + 400;  // farther and weaker
  p.second.reflectivity = static_cast<std::uint8_t>(row + 1);
  p.second.signal = static_cast<std::uint16_t>(50 + row);
  p.near_ir = 320;
  return p;
}

std::uint64_t column_time(std::uint64_t frame, std::size_t mid) {
  return kT0 + static_cast<std::uint64_t>(std::llround((static_cast<double>(frame) * 1024.0 + static_cast<double>(mid)) * kPeriod));
}

// Packet k (0..63) of frame `frame` (frame id = frame); `clock_ns`: the sensor's clock moved by that.
std::vector<std::uint8_t> frame_packet(Profile prof, std::uint32_t frame, std::size_t k, std::size_t pixels = kPixels,
                                       std::int64_t clock_ns = 0) {
  std::vector<Column> cols(16);
  for (std::size_t c = 0; c < 16; ++c) {
    const std::size_t mid = k * 16 + c;
    cols[c].measurement_id = static_cast<std::uint16_t>(mid);
    cols[c].timestamp_ns = column_time(frame, mid) + static_cast<std::uint64_t>(clock_ns);
    for (std::size_t r = 0; r < pixels; ++r) cols[c].pixels.push_back(pixel_at(mid, r));
  }
  return encode_packet(prof, pixels, frame, cols, 7654321);
}

// Independent reimplementation of ouster-sdk's projection (double precision).
std::array<double, 3> expected_xyz(const SensorMetadata& m, std::size_t mid, std::size_t row, double range_mm) {
  const double pi = std::numbers::pi;
  const double e = 2 * pi * (1.0 - static_cast<double>(mid) / m.columns_per_frame);
  const double a = -m.beam_azimuth_deg[row] * pi / 180;
  const double p = m.beam_altitude_deg[row] * pi / 180;
  const double bx = m.beam_to_lidar[3];
  const double bz = m.beam_to_lidar[11];
  const double d = std::hypot(bx, bz);
  const double l[3] = {(range_mm - d) * std::cos(e + a) * std::cos(p) + bx * std::cos(e),
                       (range_mm - d) * std::sin(e + a) * std::cos(p) + bx * std::sin(e),
                       (range_mm - d) * std::sin(p) + bz};
  const auto& t = m.lidar_to_sensor;
  std::array<double, 3> s{};
  for (int i = 0; i < 3; ++i) s[i] = (t[4 * i] * l[0] + t[4 * i + 1] * l[1] + t[4 * i + 2] * l[2] + t[4 * i + 3]) / 1000;
  return s;
}

DecoderConfig config_for(Profile prof, ReturnSelection sel = ReturnSelection::kStrongest) {
  DecoderConfig cfg;
  cfg.metadata = parse_metadata(nested_metadata(std::string(profile_spec(prof).name), kPixels), "synthetic.json");
  cfg.returns = sel;
  return cfg;
}

// Pushes frame `frame`'s packets [from, to); stamps = the packet's first column time.
std::vector<Scan> push_frame(Decoder& dec, Profile prof, std::uint32_t frame, std::size_t from = 0, std::size_t to = 64) {
  std::vector<Scan> out;
  for (std::size_t k = from; k < to; ++k) {
    const auto pkt = frame_packet(prof, frame, k);
    const auto t = dec.first_column_time(as_bytes(pkt));
    EXPECT_TRUE(t.has_value());
    if (auto s = dec.push(PacketView{as_bytes(pkt), 0, 7502}, static_cast<Nanos>(t.value_or(0)))) out.push_back(std::move(*s));
  }
  return out;
}

class EveryProfile : public ::testing::TestWithParam<Profile> {};

TEST_P(EveryProfile, KnownRangesGiveKnownPoints) {
  const Profile prof = GetParam();
  const bool dual = profile_spec(prof).returns == 2;
  Decoder dec(config_for(prof));
  EXPECT_EQ(dec.layout().packet_size, frame_packet(prof, 5, 0).size()) << "layout vs manual";
  auto scans = push_frame(dec, prof, 5);
  ASSERT_EQ(scans.size(), 1U) << "the frame's last packet ends the scan";
  const Scan& s = scans[0];
  EXPECT_EQ(s.packets, 64U);
  EXPECT_EQ(s.stamp, static_cast<Nanos>(column_time(5, 0)));
  ASSERT_EQ(s.points.size(), 1024U * kPixels);
  const auto& m = dec.config().metadata;
  const bool has_signal = profile_spec(prof).has(Field::kSignal);
  for (std::size_t i = 0; i < s.points.size(); i += 37) {
    const std::size_t mid = i / kPixels;
    const std::size_t row = i % kPixels;
    const auto& p = s.points[i];
    const Pixel px = pixel_at(mid, row);
    const auto want = expected_xyz(m, mid, row, px.first.range_mm);
    ASSERT_NEAR(p.x, want[0], 1e-4) << "mid " << mid << " row " << row;
    ASSERT_NEAR(p.y, want[1], 1e-4);
    ASSERT_NEAR(p.z, want[2], 1e-4);
    EXPECT_EQ(p.intensity, has_signal ? px.first.signal : px.first.reflectivity);
    EXPECT_EQ(p.ring, kPixels - 1 - row) << "altitudes descend with the row: ring 0 is the last beam";
    EXPECT_EQ(p.t, static_cast<std::uint32_t>(column_time(5, mid) - column_time(5, 0)));
    EXPECT_EQ(p.return_type, kReturnStrongest) << (dual ? "dual: the first echo is the stronger one" : "");
  }
  // The next frame's packets start a new scan that is complete too.
  scans = push_frame(dec, prof, 6);
  ASSERT_EQ(scans.size(), 1U);
  EXPECT_EQ(scans[0].seq, 1U);
  EXPECT_EQ(dec.stats().packets_used, 128U);
  EXPECT_EQ(dec.stats().dropped(), 0U);
  EXPECT_EQ(dec.stats().init_id_mismatches, 0U);
}

INSTANTIATE_TEST_SUITE_P(Ouster, EveryProfile,
                         ::testing::Values(Profile::kLegacy, Profile::kRng19Rfl8Sig16Nir16,
                                           Profile::kRng19Rfl8Sig16Nir16Dual, Profile::kRng15Rfl8Nir8,
                                           Profile::kRng15Rfl8Win8, Profile::kFiveWordPixel,
                                           Profile::kFusaRng15Rfl8Nir8Dual, Profile::kRng15Rfl8Nir8Dual));

TEST(OusterDecoder, PacketAccessorsReadTheManualLayout) {
  const auto pkt = frame_packet(Profile::kRng19Rfl8Sig16Nir16Dual, 77, 3);
  const auto l = config_for(Profile::kRng19Rfl8Sig16Nir16Dual).metadata.layout();
  const auto h = read_packet_header(as_bytes(pkt), l);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->packet_type, 1);
  EXPECT_EQ(h->frame_id, 77U);
  EXPECT_EQ(h->init_id, 7654321U);
  const auto c = read_column_header(as_bytes(pkt), l, 5);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->measurement_id, 53);
  EXPECT_TRUE(c->valid());
  EXPECT_EQ(*read_field(as_bytes(pkt), l, 5, 2, Field::kRange), pixel_at(53, 2).first.range_mm);
  EXPECT_EQ(*read_field(as_bytes(pkt), l, 5, 2, Field::kRange2), pixel_at(53, 2).second.range_mm);
  EXPECT_EQ(*read_field(as_bytes(pkt), l, 5, 2, Field::kSignal2), pixel_at(53, 2).second.signal);
  EXPECT_EQ(*read_field(as_bytes(pkt), l, 5, 2, Field::kNearIr), 320U);
  EXPECT_FALSE(read_field(as_bytes(pkt), l, 16, 0, Field::kRange)) << "column out of range";
  EXPECT_FALSE(read_field(as_bytes(pkt), l, 0, kPixels, Field::kRange)) << "pixel out of range";
  EXPECT_FALSE(read_column_header(as_bytes(pkt).first(100), l, 0)) << "short buffer";
  const auto fusa = frame_packet(Profile::kFusaRng15Rfl8Nir8Dual, 70000, 0);
  const auto lf = config_for(Profile::kFusaRng15Rfl8Nir8Dual).metadata.layout();
  EXPECT_EQ(read_packet_header(as_bytes(fusa), lf)->frame_id, 70000U) << "FuSa frame id is 32 bits";
  const auto lb = config_for(Profile::kRng15Rfl8Nir8).metadata.layout();
  EXPECT_EQ(*read_field(as_bytes(frame_packet(Profile::kRng15Rfl8Nir8, 1, 0)), lb, 0, 0, Field::kNearIr), 320U)
      << "near-IR is sent divided by 16";
}

TEST(OusterDecoder, HandCheckedGeometry) {
  // One beam at 0 deg altitude and azimuth, no beam offset: column 0 points along the lidar's +x,
  // which Ouster's lidar_to_sensor (diag -1 -1 1, z + 36.18 mm) turns to the sensor's -x (the
  // connector side); a quarter frame later the beam points to the sensor's +y (left).
  auto j = nlohmann::json::parse(nested_metadata("RNG19_RFL8_SIG16_NIR16", 1, 1024, 10, 0.0));
  j["beam_intrinsics"]["beam_altitude_angles"] = {0.0};
  j["beam_intrinsics"]["beam_azimuth_angles"] = {0.0};
  DecoderConfig cfg;
  cfg.metadata = parse_metadata(j.dump(), "one_beam.json");
  // A packet's columns carry consecutive measurement ids (one off them is corrupt, issue 26 item 5):
  // columns 0.. and, in a second packet, the quarter frame's 256...
  const auto decode = [&](std::uint16_t first_id) {
    std::vector<Column> cols(16);
    for (std::size_t c = 0; c < 16; ++c) {
      cols[c].measurement_id = static_cast<std::uint16_t>(first_id + c);
      cols[c].timestamp_ns = kT0 + c;
      cols[c].pixels = {Pixel{{10000, 1, 1}, {}, 0}};
    }
    const auto pkt = encode_packet(Profile::kRng19Rfl8Sig16Nir16, 1, 1, cols);
    cfg.emit_partial_scans = true;
    Decoder partial(cfg);
    EXPECT_FALSE(partial.push(PacketView{as_bytes(pkt), 0, 7502}, 0));
    return partial.flush();
  };
  const auto s = decode(0);
  ASSERT_TRUE(s);
  ASSERT_EQ(s->points.size(), 16U);
  EXPECT_NEAR(s->points[0].x, -10.0, 1e-5);
  EXPECT_NEAR(s->points[0].y, 0.0, 1e-5);
  EXPECT_NEAR(s->points[0].z, 0.03618, 1e-6);
  EXPECT_EQ(s->points[1].t, 1U) << "t = column time - first column time";
  const auto q = decode(256);
  ASSERT_TRUE(q);
  ASSERT_EQ(q->points.size(), 16U);
  EXPECT_NEAR(q->points[0].x, 0.0, 1e-5);
  EXPECT_NEAR(q->points[0].y, 10.0, 1e-5);
}

TEST(OusterDecoder, DualReturnSelection) {
  const Profile prof = Profile::kRng19Rfl8Sig16Nir16Dual;
  for (const auto sel : {ReturnSelection::kStrongest, ReturnSelection::kLast, ReturnSelection::kDual}) {
    Decoder dec(config_for(prof, sel));
    const auto scans = push_frame(dec, prof, 1);
    ASSERT_EQ(scans.size(), 1U);
    const auto& pts = scans[0].points;
    const auto& m = dec.config().metadata;
    const Pixel px = pixel_at(0, 0);
    if (sel == ReturnSelection::kDual) {
      ASSERT_EQ(pts.size(), 2U * 1024U * kPixels);
      EXPECT_EQ(pts[0].return_type, kReturnStrongest);
      EXPECT_EQ(pts[1].return_type, kReturnLast);
      EXPECT_EQ(pts[1].intensity, px.second.signal);
      EXPECT_NEAR(pts[1].x, expected_xyz(m, 0, 0, px.second.range_mm)[0], 1e-4);
    } else if (sel == ReturnSelection::kLast) {
      ASSERT_EQ(pts.size(), 1024U * kPixels);
      EXPECT_EQ(pts[0].return_type, kReturnLast);
      EXPECT_NEAR(pts[0].x, expected_xyz(m, 0, 0, px.second.range_mm)[0], 1e-4);
    } else {
      ASSERT_EQ(pts.size(), 1024U * kPixels);
      EXPECT_EQ(pts[0].return_type, kReturnStrongest);
      EXPECT_NEAR(pts[0].x, expected_xyz(m, 0, 0, px.first.range_mm)[0], 1e-4);
    }
  }
}

TEST(OusterDecoder, PartialFirstScanAndFrameIdCut) {
  const Profile prof = Profile::kLegacy;
  Decoder dec(config_for(prof));
  EXPECT_TRUE(push_frame(dec, prof, 3, 10, 64).empty()) << "joined mid-frame: partial, not emitted";
  EXPECT_EQ(dec.stats().partial_scans_discarded, 1U);
  // Frame 4 loses its last packet: the frame id change of frame 5 ends it.
  EXPECT_TRUE(push_frame(dec, prof, 4, 0, 63).empty());
  const auto s = push_frame(dec, prof, 5, 0, 1);
  ASSERT_EQ(s.size(), 1U);
  EXPECT_EQ(s[0].seq, 0U);
  EXPECT_EQ(s[0].packets, 63U);
  EXPECT_EQ(s[0].points.size(), 63U * 16U * kPixels);
  const auto tail = dec.flush();
  ASSERT_TRUE(tail);
  EXPECT_EQ(tail->packets, 1U);

  auto cfg = config_for(prof);
  cfg.emit_partial_scans = true;
  Decoder all(cfg);
  const auto first = push_frame(all, prof, 3, 10, 64);
  ASSERT_EQ(first.size(), 1U);
  EXPECT_EQ(first[0].packets, 54U);
}

TEST(OusterDecoder, InvalidColumnsAndRangeFilter) {
  const Profile prof = Profile::kRng19Rfl8Sig16Nir16;
  auto cfg = config_for(prof);
  cfg.min_range_m = 4.05;  // ranges are 4.000 .. 4.448 m
  cfg.max_range_m = 4.2;
  cfg.emit_partial_scans = true;
  Decoder dec(cfg);
  std::vector<Column> cols(16);
  std::size_t expected = 0;
  for (std::size_t c = 0; c < 16; ++c) {
    cols[c].measurement_id = static_cast<std::uint16_t>(c);
    cols[c].timestamp_ns = kT0 + c * 1000;
    cols[c].valid = c % 4 != 1;
    for (std::size_t r = 0; r < kPixels; ++r) {
      cols[c].pixels.push_back(pixel_at(c, r));
      const double d = pixel_at(c, r).first.range_mm / 1000.0;
      if (cols[c].valid && d >= 4.05 && d <= 4.2) ++expected;
    }
  }
  cols[7].measurement_id = 4000;  // beyond columns_per_frame
  for (const auto& p : cols[7].pixels) {
    const double d = p.first.range_mm / 1000.0;
    if (d >= 4.05 && d <= 4.2) --expected;
  }
  const auto pkt = encode_packet(prof, kPixels, 9, cols);
  EXPECT_FALSE(dec.push(PacketView{as_bytes(pkt), 0, 7502}, 5));
  const auto s = dec.flush();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->points.size(), expected);
  EXPECT_EQ(dec.stats().invalid_columns, 4U);
  EXPECT_EQ(dec.stats().bad_measurement_ids, 1U);
  for (const auto& p : s->points) {
    const double d = std::sqrt(static_cast<double>(p.x * p.x + p.y * p.y + p.z * p.z));
    EXPECT_GT(d, 3.9);
  }
}

// The limits keep both ends (to the millimetre), range 0 is never a point, and limits that round
// to an empty millimetre interval keep nothing (the hot loop's single unsigned compare).
TEST(OusterDecoder, RangeLimitsAreInclusiveAndRangeZeroIsNoReturn) {
  const Profile prof = Profile::kRng19Rfl8Sig16Nir16;
  const std::uint32_t ranges[] = {0, 3999, 4000, 4001, 4999, 5000, 5001, 1};
  std::vector<Column> cols(16);
  for (std::size_t c = 0; c < 16; ++c) {
    cols[c].measurement_id = static_cast<std::uint16_t>(c);
    cols[c].timestamp_ns = kT0 + c * 1000;
    for (std::size_t r = 0; r < kPixels; ++r) {
      cols[c].pixels.push_back(pixel_at(c, r));
      cols[c].pixels.back().first.range_mm = ranges[(c + r) % std::size(ranges)];
    }
  }
  const auto pkt = encode_packet(prof, kPixels, 9, cols);
  const auto points_with = [&](double min_m, double max_m) {
    auto cfg = config_for(prof);
    cfg.min_range_m = min_m;
    cfg.max_range_m = max_m;
    cfg.emit_partial_scans = true;
    Decoder dec(cfg);
    EXPECT_FALSE(dec.push(PacketView{as_bytes(pkt), 0, 7502}, 5));
    const auto s = dec.flush();
    return s ? s->points.size() : std::size_t{0};
  };
  const std::size_t per_value = 16 * kPixels / std::size(ranges);  // each value on 32 pixels
  EXPECT_EQ(points_with(0.0, std::numeric_limits<double>::infinity()), 7 * per_value);
  EXPECT_EQ(points_with(4.0, 5.0), 4 * per_value);  // 4000, 4001, 4999, 5000
  EXPECT_EQ(points_with(4.0001, 4.0009), 0U);       // [4001, 4000] mm: empty
}

TEST(OusterDecoder, BadPacketsAreCountedDrops) {
  const Profile prof = Profile::kRng19Rfl8Sig16Nir16;
  Decoder dec(config_for(prof));
  auto good = frame_packet(prof, 2, 0);
  auto truncated = good;
  truncated.resize(good.size() - 1);
  EXPECT_FALSE(dec.push(PacketView{as_bytes(truncated), 0, 7502}, 0));
  EXPECT_EQ(dec.last_status(), PacketStatus::kWrongSize);
  std::vector<std::uint8_t> imu(48, 0);
  EXPECT_FALSE(dec.push(PacketView{as_bytes(imu), 0, 7503}, 0));
  EXPECT_EQ(dec.last_status(), PacketStatus::kNotData);
  auto not_lidar = good;
  not_lidar[0] = 2;  // packet type
  EXPECT_FALSE(dec.push(PacketView{as_bytes(not_lidar), 0, 7502}, 0));
  EXPECT_EQ(dec.last_status(), PacketStatus::kNotData);
  EXPECT_FALSE(dec.push(PacketView{{}, 0, 7502}, 0));
  EXPECT_FALSE(dec.first_column_time(as_bytes(truncated)));
  // Random bytes of the right size with the lidar packet type: decoded or counted, points finite.
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int k = 0; k < 200; ++k) {
    std::vector<std::uint8_t> junk(good.size());
    for (auto& b : junk) b = static_cast<std::uint8_t>(byte(rng));
    junk[0] = 1;
    junk[1] = 0;
    const auto stamp = static_cast<Nanos>(dec.first_column_time(as_bytes(junk)).value_or(0) & 0xFFFFFFFFFFFF);
    if (auto s = dec.push(PacketView{as_bytes(junk), 0, 7502}, stamp)) {
      for (const auto& p : s->points) ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    }
  }
  const auto& st = dec.stats();
  EXPECT_EQ(st.by_status[static_cast<std::size_t>(PacketStatus::kWrongSize)], 2U);
  EXPECT_EQ(st.by_status[static_cast<std::size_t>(PacketStatus::kNotData)], 2U);
  EXPECT_EQ(st.packets, 204U);
  EXPECT_EQ(st.packets_used + st.dropped(), st.packets);
  EXPECT_GT(st.bad_measurement_ids + st.invalid_columns, 0U);
  EXPECT_GT(st.init_id_mismatches, 0U);
  // The drops are visible in the next emitted scan.
  Decoder d2(config_for(prof));
  (void)d2.push(PacketView{as_bytes(truncated), 0, 7502}, 0);
  const auto s = push_frame(d2, prof, 2);
  ASSERT_EQ(s.size(), 1U);
  EXPECT_EQ(s[0].dropped, 1U);
}

TEST(OusterDecoder, TimeJumpEndsScanAsPartial) {
  const Profile prof = Profile::kLegacy;
  Decoder dec(config_for(prof));
  (void)push_frame(dec, prof, 1, 0, 30);
  // Same frame id, but the sensor's clock jumped back 10 s and stays there (its column times, and
  // the stamps mapped from them): the scan in progress is partial. The first packet of the step is
  // judged alone (its ids continue: a corrupt time, dropped); the second confirms the step (issue 26
  // item 2).
  constexpr std::int64_t kBack = -10'000'000'000;
  const auto pkt = frame_packet(prof, 1, 30, kPixels, kBack);
  EXPECT_FALSE(dec.push(PacketView{as_bytes(pkt), 0, 7502}, static_cast<Nanos>(column_time(1, 480)) + kBack));
  EXPECT_EQ(dec.stats().time_jumps, 0U);
  EXPECT_EQ(dec.stats().by_status[static_cast<std::size_t>(PacketStatus::kBadTime)], 1U);
  const auto pkt2 = frame_packet(prof, 1, 31, kPixels, kBack);
  EXPECT_FALSE(dec.push(PacketView{as_bytes(pkt2), 0, 7502}, static_cast<Nanos>(column_time(1, 496)) + kBack));
  EXPECT_EQ(dec.stats().time_jumps, 1U);
  EXPECT_EQ(dec.stats().partial_scans_discarded, 1U);
}

// A host CLOCK_REALTIME step back of 500 ms in the middle of a frame (issue 26, the LIDAR campaign's
// OS-LEGACY: the scan across the step was discarded and counted lost, a packet dropped for its
// time): the driver's mapping follows the host, so the stamps step, but the PTP-synced sensor's
// column times go on. The frame is whole and published on the line it began on (stamp, and every
// point's t, from the column times); the next frame takes the moved mapping.
TEST(OusterDecoder, AHostClockStepMovesTheStampsNotTheSensorsFrame) {
  const Profile prof = Profile::kLegacy;
  Decoder dec(config_for(prof));
  (void)push_frame(dec, prof, 4);  // frame 4: locked on
  constexpr Nanos kStep = -500'000'000;
  std::vector<Scan> out;
  for (std::size_t k = 0; k < 64; ++k) {
    const auto pkt = frame_packet(prof, 5, k);
    const Nanos stamp = static_cast<Nanos>(column_time(5, k * 16)) + (k >= 23 ? kStep : 0);
    if (auto s = dec.push(PacketView{as_bytes(pkt), 0, 7502}, stamp)) out.push_back(std::move(*s));
  }
  const auto next = push_frame(dec, prof, 6);  // stamps still the frame's column times: see below
  EXPECT_EQ(dec.stats().time_jumps, 0U);
  EXPECT_EQ(dec.stats().by_status[static_cast<std::size_t>(PacketStatus::kBadTime)], 0U);
  EXPECT_EQ(dec.stats().mapping_steps, 1U);
  ASSERT_EQ(out.size(), 1U) << "frame 5 published, whole";
  EXPECT_EQ(out[0].packets, 64U);
  EXPECT_EQ(out[0].missing_packets, 0U);
  EXPECT_EQ(out[0].dropped, 0U);
  EXPECT_EQ(out[0].stamp, static_cast<Nanos>(column_time(5, 0)));
  std::uint32_t max_t = 0;
  for (const auto& p : out[0].points) max_t = std::max(max_t, p.t);
  EXPECT_EQ(max_t, static_cast<std::uint32_t>(column_time(5, 1023) - column_time(5, 0))) << "t on the column times";
  // push_frame stamps frame 6 with its column times: the mapping moved back (+500 ms) between two
  // frames, so frame 6 takes it at its first packet and is whole too.
  ASSERT_EQ(next.size(), 1U);
  EXPECT_EQ(next[0].stamp, static_cast<Nanos>(column_time(6, 0)));
  EXPECT_EQ(next[0].packets, 64U);
}

// A packet whose every column reads invalid (its status words damaged; the sensor sends no packet
// wholly outside its column window) carries nothing to place or decode: one packet of its frame,
// counted dropped once, never also missing. Before, it was counted one of the scan's packets, and
// the gap it seemed to leave counted it missing as well. First, middle and last packet of a frame.
TEST(OusterDecoder, APacketOfOnlyInvalidColumnsIsDroppedOnceNeverMissing) {
  const Profile prof = Profile::kLegacy;
  for (const std::size_t bad : {std::size_t{0}, std::size_t{20}, std::size_t{63}}) {
    SCOPED_TRACE("invalid packet " + std::to_string(bad));
    Decoder dec(config_for(prof));
    (void)push_frame(dec, prof, 4);  // locked on
    std::vector<Scan> out;
    for (std::size_t k = 0; k < 64; ++k) {
      std::vector<Column> cols(16);
      for (std::size_t c = 0; c < 16; ++c) {
        const std::size_t mid = k * 16 + c;
        cols[c].measurement_id = static_cast<std::uint16_t>(mid);
        cols[c].timestamp_ns = column_time(5, mid);
        cols[c].valid = k != bad;
        for (std::size_t r = 0; r < kPixels; ++r) cols[c].pixels.push_back(pixel_at(mid, r));
      }
      const auto pkt = encode_packet(prof, kPixels, 5, cols, 7654321);
      if (auto s = dec.push(PacketView{as_bytes(pkt), 0, 7502}, static_cast<Nanos>(column_time(5, k * 16)))) out.push_back(std::move(*s));
    }
    for (auto& s : push_frame(dec, prof, 6)) out.push_back(std::move(s));
    ASSERT_GE(out.size(), 1U);
    const Scan& s5 = out[0];
    EXPECT_EQ(s5.stamp, static_cast<Nanos>(column_time(5, bad == 0 ? 16 : 0)));
    EXPECT_EQ(s5.missing_packets, 0U);
    EXPECT_EQ(s5.dropped, 1U);
    EXPECT_EQ(s5.packets + s5.dropped, 64U) << s5.packets << " packets";
    EXPECT_EQ(s5.points.size(), 63U * 16U * kPixels);
    EXPECT_EQ(dec.stats().invalid_columns, 16U);
    // Frame 6 whole, on its own.
    ASSERT_EQ(out.size(), 2U);
    EXPECT_EQ(out[1].missing_packets, 0U);
    EXPECT_EQ(out[1].dropped, 0U);
    EXPECT_EQ(out[1].points.size(), 64U * 16U * kPixels);
  }
}

TEST(OusterDecoder, ScanDecoderInterface) {
  DecoderOptions o;
  o.model = "OS";
  o.metadata_text = nested_metadata("RNG15_RFL8_NIR8", kPixels);
  o.metadata_name = "lb.json";
  auto dec = make_decoder(o);
  const auto pkt = frame_packet(Profile::kRng15Rfl8Nir8, 1, 0);
  const auto t = dec->packet_time(as_bytes(pkt));
  EXPECT_EQ(t.kind, SensorTime::Kind::kAbsoluteNs);
  EXPECT_EQ(t.value, static_cast<Nanos>(column_time(1, 0)));
  EXPECT_EQ(dec->packet_span_ns(), 1'562'500) << "16 columns x 97.65625 us";
  EXPECT_TRUE(dec->is_data_packet(PacketView{as_bytes(pkt), 0, 7502}));
  EXPECT_FALSE(dec->is_data_packet(PacketView{as_bytes(pkt), 0, 7503})) << "the IMU port";
  std::vector<std::uint8_t> imu(48);
  EXPECT_FALSE(dec->is_data_packet(PacketView{as_bytes(imu), 0, 7502}));
  EXPECT_EQ(dec->packet_time(as_bytes(imu)).kind, SensorTime::Kind::kNone);
  (void)dec->push(PacketView{as_bytes(imu), 0, 7502}, 0);
  EXPECT_EQ(dec->counters().dropped(), 1U);
  EXPECT_EQ(dec->last_status(), PacketStatus::kNotData);
}

}  // namespace
}  // namespace sensor_rig::lidar::ouster::test
