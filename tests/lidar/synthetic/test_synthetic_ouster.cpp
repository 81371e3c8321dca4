// Synthetic Ouster sensor: its metadata parses back to itself, its packets are genuine (layout,
// column headers, timing, frame ids, status), and the real decoder turns them back into the scene
// (every point on a surface within the range resolution) with complete scans of every column.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/packet.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::mock {
namespace {

using ouster::Profile;

constexpr Nanos kStart = 1'700'000'123'456'789'000LL;

ouster::SensorMetadata nominal(Profile p, int beams = 32, const char* mode = "1024x10") {
  NominalOuster n;
  n.profile = p;
  n.beams = beams;
  n.lidar_mode = mode;
  return nominal_ouster_metadata(n);
}

SyntheticOuster make(const ouster::SensorMetadata& m, int start_column = 0) {
  SyntheticOusterConfig c;
  c.metadata = m;
  c.start_ns = kStart;
  c.start_column = start_column;
  c.first_frame_id = 65530;  // wraps within a test
  return SyntheticOuster(c, Scene::standard());
}

TEST(SyntheticOusterMetadata, ParsesBackToTheSameSensor) {
  for (const Profile p : {Profile::kLegacy, Profile::kRng19Rfl8Sig16Nir16, Profile::kRng15Rfl8Nir8,
                          Profile::kFusaRng15Rfl8Nir8Dual}) {
    const auto m = nominal(p, 64, "2048x10");
    const auto back = ouster::parse_metadata(metadata_json(m), "synthetic.json");
    SCOPED_TRACE(std::string(ouster::profile_spec(p).name));
    EXPECT_EQ(back.nested_format, p != Profile::kLegacy);  // LEGACY: FW 2.1 flat file; eUDP: FW 2.4+ nested
    EXPECT_EQ(back.profile, p);
    EXPECT_EQ(back.header_type, m.header_type);
    EXPECT_EQ(back.pixels_per_column, 64);
    EXPECT_EQ(back.columns_per_frame, 2048);
    EXPECT_EQ(back.columns_per_packet, 16);
    EXPECT_DOUBLE_EQ(back.frames_per_second, 10.0);
    EXPECT_EQ(back.lidar_mode, "2048x10");
    EXPECT_EQ(back.beam_altitude_deg, m.beam_altitude_deg);
    EXPECT_EQ(back.beam_azimuth_deg, m.beam_azimuth_deg);
    EXPECT_EQ(back.pixel_shift_by_row, m.pixel_shift_by_row);
    EXPECT_EQ(back.beam_to_lidar, m.beam_to_lidar);
    EXPECT_EQ(back.lidar_to_sensor, m.lidar_to_sensor);
    EXPECT_EQ(back.init_id, m.init_id);
    EXPECT_EQ(back.udp_port_lidar, 7502);
    EXPECT_EQ(back.udp_port_imu, 7503);
    EXPECT_EQ(back.column_window_first, 0);
    EXPECT_EQ(back.column_window_last, 2047);
  }
  // The nominal OS-1: 33.2° of uniformly spaced beams, top beam first.
  const auto m = nominal(Profile::kLegacy);
  EXPECT_DOUBLE_EQ(m.beam_altitude_deg.front(), 16.6);
  EXPECT_DOUBLE_EQ(m.beam_altitude_deg.back(), -16.6);
  EXPECT_EQ(m.layout().packet_size, 16u * (16 + 32 * 12 + 4));  // 6464 bytes
}

TEST(SyntheticOusterMetadata, RejectsWhatNoSensorHas) {
  NominalOuster n;
  n.beams = 48;
  EXPECT_THROW(nominal_ouster_metadata(n), std::invalid_argument);
  n.beams = 32;
  n.lidar_mode = "1000x10";
  EXPECT_THROW(nominal_ouster_metadata(n), std::invalid_argument);
  SyntheticOusterConfig c;
  c.metadata = nominal(Profile::kLegacy);
  c.start_column = 8;  // not the first column of a packet
  EXPECT_THROW(SyntheticOuster(c, Scene::standard()), std::invalid_argument);
  c.start_column = 0;
  c.metadata.beam_azimuth_deg.pop_back();
  EXPECT_THROW(SyntheticOuster(c, Scene::standard()), std::invalid_argument);
}

struct Case {
  Profile profile;
  int beams;
  const char* mode;
};

class SyntheticOusterProfiles : public testing::TestWithParam<Case> {};

TEST_P(SyntheticOusterProfiles, PacketsAreGenuine) {
  const auto m = nominal(GetParam().profile, GetParam().beams, GetParam().mode);
  const auto s = make(m, 1024 - 64);  // four packets before the frame ends
  const auto& l = s.layout();
  const double col_ns = 1e9 / (m.frames_per_second * m.columns_per_frame);
  EXPECT_NEAR(s.packets_per_second(), m.frames_per_second * m.columns_per_frame / 16.0, 1e-9);
  std::vector<std::byte> buf(l.packet_size);
  std::uint64_t prev_ts = 0;
  int prev_mid = -1;
  std::size_t returns = 0, pixels = 0;
  for (std::uint64_t k = 0; k < 200; ++k) {
    s.render_packet(k, buf);
    ASSERT_EQ(ouster::check_packet(buf, l), PacketStatus::kOk) << "packet " << k;
    const auto header = ouster::read_packet_header(buf, l);
    ASSERT_TRUE(header);
    if (l.header != ouster::HeaderType::kLegacy) {
      EXPECT_EQ(header->packet_type, ouster::kLidarPacketType);
      EXPECT_EQ(header->init_id, m.init_id);
      EXPECT_EQ(header->prod_sn, 992300000001ULL);
    }
    for (std::size_t c = 0; c < l.columns_per_packet; ++c) {
      const auto col = ouster::read_column_header(buf, l, c);
      ASSERT_TRUE(col);
      EXPECT_TRUE(col->valid());
      const int mid = (prev_mid + 1) % m.columns_per_frame;
      if (prev_mid >= 0) {
        EXPECT_EQ(col->measurement_id, mid);
        EXPECT_NEAR(static_cast<double>(col->timestamp_ns - prev_ts), col_ns, 1.0);
      }
      // Frame ids count frames (16 bits in LEGACY columns, in the header otherwise) and wrap.
      const auto frame = static_cast<std::uint32_t>(65530 + (1024 - 64 + k * 16 + c) / 1024);
      if (l.header == ouster::HeaderType::kLegacy) {
        EXPECT_EQ(col->frame_id, static_cast<std::uint16_t>(frame));
        EXPECT_EQ(col->encoder_count, col->measurement_id * 90112u / 1024u);
      } else {
        EXPECT_EQ(header->frame_id, frame & 0xFFFFu);
      }
      prev_mid = col->measurement_id;
      prev_ts = col->timestamp_ns;
      for (std::size_t px = 0; px < l.pixels_per_column; ++px, ++pixels)
        returns += *ouster::read_field(buf, l, c, px, ouster::Field::kRange) != 0 ? 1 : 0;
    }
    EXPECT_EQ(ouster::read_column_header(buf, l, 0)->timestamp_ns, static_cast<std::uint64_t>(s.packet_time(k)));
  }
  // Beams below the horizon see the ground and walls; the top ones look over the walls.
  EXPECT_GT(returns, pixels / 2);
  EXPECT_LT(returns, pixels);
}

// Decoded with the real decoder: every point on a scene surface within half the range unit (plus
// float rounding), as many points as non-zero ranges went out, whole frames of every column.
TEST_P(SyntheticOusterProfiles, RoundTripThroughDecoderReproducesScene) {
  const auto m = nominal(GetParam().profile, GetParam().beams, GetParam().mode);
  const auto s = make(m, 512);  // starts mid-frame: the first scan is partial
  const auto& l = s.layout();
  ouster::DecoderConfig dc;
  dc.metadata = m;
  dc.intensity = ouster::IntensitySource::kReflectivity;
  ouster::Decoder dec(dc);
  const auto& range = ouster::profile_spec(m.profile).field(ouster::Field::kRange);
  const double unit_m = static_cast<double>(1u << range.upshift) * 1e-3;

  const auto per_frame = static_cast<std::uint64_t>(m.columns_per_frame / m.columns_per_packet);
  const std::uint64_t packets = per_frame / 2 + 2 * per_frame + 3;  // half, two whole frames, a bit
  std::vector<std::byte> buf(l.packet_size);
  std::vector<Scan> scans;
  std::vector<std::size_t> nonzero_per_frame(4, 0);
  for (std::uint64_t k = 0; k < packets; ++k) {
    s.render_packet(k, buf);
    const std::uint64_t frame = (k * 16 + 512) / static_cast<std::uint64_t>(m.columns_per_frame);
    for (std::size_t c = 0; c < l.columns_per_packet; ++c)
      for (std::size_t px = 0; px < l.pixels_per_column; ++px)
        nonzero_per_frame[frame] += *ouster::read_field(buf, l, c, px, ouster::Field::kRange) != 0 ? 1 : 0;
    const Nanos t = s.packet_time(k);
    if (auto scan = dec.push(PacketView{buf, t + 1'000'000, 7502}, t)) scans.push_back(std::move(*scan));
    ASSERT_EQ(dec.last_status(), PacketStatus::kOk);
  }
  // The partial first frame is not emitted; frames 1 and 2 are complete, frame 3 is in progress.
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(dec.stats().partial_scans_discarded, 1u);
  EXPECT_EQ(dec.stats().init_id_mismatches, 0u);
  const Nanos frame_ns = static_cast<Nanos>(1e9 / m.frames_per_second);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const Scan& scan = scans[i];
    EXPECT_EQ(scan.packets, per_frame) << "scan " << i;
    EXPECT_EQ(scan.points.size(), nonzero_per_frame[i + 1]) << "scan " << i;
    // Stamped at the frame's first column (measurement id 0), its last point one frame later.
    EXPECT_EQ(scan.stamp, kStart + std::llround((static_cast<double>(m.columns_per_frame) * static_cast<double>(i + 1) - 512) * s.column_period_ns()));
    std::set<std::uint16_t> rings;
    std::uint32_t max_t = 0;
    std::size_t off = 0, wrong_refl = 0;
    double worst = 0;
    for (const PointXYZIRT& pt : scan.points) {
      const Vec3 v{static_cast<double>(pt.x), static_cast<double>(pt.y), static_cast<double>(pt.z)};
      const double r = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
      const double tol = unit_m / 2 + 2e-6 * r + 1e-4;
      std::size_t which = 0;
      const double d = s.scene().distance_to_surface(v, &which);
      worst = std::max(worst, d / tol);
      off += d > tol ? 1 : 0;
      // Reflectivity is the surface's (at an edge either neighbour's).
      bool match = false;
      for (const Surface& surf : s.scene().surfaces()) {
        if (surf.reflectivity != static_cast<std::uint8_t>(pt.intensity)) continue;
        Scene one;
        one.add(surf);
        match = match || one.distance_to_surface(v) <= tol;
      }
      wrong_refl += match ? 0 : 1;
      rings.insert(pt.ring);
      max_t = std::max(max_t, pt.t);
    }
    EXPECT_EQ(off, 0u) << "scan " << i << ": worst distance / tolerance " << worst;
    EXPECT_EQ(wrong_refl, 0u) << "scan " << i;
    EXPECT_GT(rings.size(), static_cast<std::size_t>(m.pixels_per_column / 2));  // the top beams may see nothing
    EXPECT_LE(rings.size(), static_cast<std::size_t>(m.pixels_per_column));
    EXPECT_NEAR(static_cast<double>(max_t), static_cast<double>(frame_ns) - s.column_period_ns(), s.column_period_ns() * 16);
  }
  EXPECT_EQ(scans[1].stamp - scans[0].stamp, frame_ns);
}

INSTANTIATE_TEST_SUITE_P(Profiles, SyntheticOusterProfiles,
                         testing::Values(Case{Profile::kLegacy, 32, "1024x10"}, Case{Profile::kLegacy, 64, "1024x20"},
                                         Case{Profile::kRng19Rfl8Sig16Nir16, 32, "1024x10"},
                                         Case{Profile::kRng19Rfl8Sig16Nir16Dual, 16, "1024x10"},
                                         Case{Profile::kRng15Rfl8Nir8, 32, "1024x10"},
                                         Case{Profile::kFusaRng15Rfl8Nir8Dual, 32, "1024x20"}),
                         [](const auto& i) {
                           std::string n(ouster::profile_spec(i.param.profile).name);
                           return n + "_" + std::to_string(i.param.beams) + "_" + std::string(i.param.mode).substr(5);
                         });

// Through the registry as the driver uses it: the metadata JSON in, the packet's sensor time out
// (= the first column's timestamp, vehicle time from the host clock), a scan per frame.
TEST(SyntheticOuster, DriverPathSeesHostClockTimeAndFullFrames) {
  const auto m = nominal(Profile::kLegacy);
  auto s = make(m);
  DecoderOptions o;
  o.model = "OS-LEGACY";
  o.metadata_text = metadata_json(m);
  o.metadata_name = "synthetic.json";
  auto dec = make_decoder(o);
  ASSERT_EQ(dec->packet_span_ns(), std::llround(16 * s.column_period_ns()));
  std::size_t scans = 0;
  Nanos prev = 0;
  for (int k = 0; k < 64 * 3; ++k) {
    const SyntheticPacket p = s.next();
    // The packet goes out when its last column is measured: the decoder's span after its first.
    EXPECT_NEAR(static_cast<double>(p.time_ns - s.packet_time(static_cast<std::uint64_t>(k))),
                static_cast<double>(dec->packet_span_ns()), 1.0);
    const auto t = dec->packet_time(p.bytes);
    ASSERT_EQ(t.kind, SensorTime::Kind::kAbsoluteNs);
    EXPECT_EQ(t.value, s.packet_time(static_cast<std::uint64_t>(k)));
    EXPECT_GT(t.value, prev);
    prev = t.value;
    ASSERT_TRUE(dec->is_data_packet(PacketView{p.bytes, p.time_ns, 7502}));
    if (auto scan = dec->push(PacketView{p.bytes, p.time_ns, 7502}, t.value)) {
      ++scans;
      EXPECT_EQ(scan->packets, 64u);
      EXPECT_GT(scan->points.size(), 10000u);
    }
  }
  EXPECT_EQ(scans, 3u);  // starts at column 0: every frame complete
  EXPECT_EQ(dec->counters().dropped(), 0u);
}

// Columns outside the column window go out invalid and empty, as the sensor sends them.
TEST(SyntheticOuster, ColumnWindowLeavesOtherColumnsInvalid) {
  auto m = nominal(Profile::kRng19Rfl8Sig16Nir16);
  m.column_window_first = 256;
  m.column_window_last = 767;
  const auto s = make(m);
  std::vector<std::byte> buf(s.layout().packet_size);
  std::size_t valid = 0;
  for (std::uint64_t k = 0; k < 64; ++k) {
    s.render_packet(k, buf);
    for (std::size_t c = 0; c < 16; ++c) {
      const auto h = *ouster::read_column_header(buf, s.layout(), c);
      const bool in = h.measurement_id >= 256 && h.measurement_id <= 767;
      EXPECT_EQ(h.valid(), in) << h.measurement_id;
      valid += h.valid() ? 1 : 0;
      if (!in) {
        EXPECT_EQ(*ouster::read_field(buf, s.layout(), c, 20, ouster::Field::kRange), 0u);
      }
    }
  }
  EXPECT_EQ(valid, 512u);
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
