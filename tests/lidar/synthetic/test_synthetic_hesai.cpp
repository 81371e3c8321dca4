// Synthetic Hesai sensor (Pandar40P, PandarXT32): genuine packets (layout, marks, azimuth steps at
// the model's firing rate, UTC tail time, return mode, header and sequence), and decoding them with
// the real decoder reproduces the scene: exactly once the decoder's firing-time model is undone,
// and within the rotation during one firing group as the decoder places them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "sensor_rig/lidar/hesai/decoder.hpp"
#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"
#include "sensor_rig/lidar/mock/synthetic_hesai.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::mock {
namespace {

using hesai::Model;
using hesai::ReturnMode;

constexpr Nanos kStart = 1'700'000'123'456'789'123LL;  // 2023-11-14 22:15:23.456789123 UTC
constexpr double kDegToRad = std::numbers::pi / 180.0;

struct Case {
  Model model;
  ReturnMode mode;
  double rpm;
  double expected_pps;  // the user manual's packet rate
  double az_step;       // block azimuth step, 0.01°
};

class SyntheticHesaiModels : public testing::TestWithParam<Case> {
 protected:
  SyntheticHesai make(double start_azimuth = 90.0) const {
    SyntheticHesaiConfig c;
    c.model = GetParam().model;
    c.return_mode = GetParam().mode;
    c.rpm = GetParam().rpm;
    c.start_ns = kStart;
    c.start_azimuth_deg = start_azimuth;
    return SyntheticHesai(c, Scene::standard());
  }
};

TEST_P(SyntheticHesaiModels, PacketsAreGenuine) {
  const Case& p = GetParam();
  const auto s = make();
  const auto& mi = hesai::model_info(p.model);
  const int echoes = hesai::return_count(static_cast<std::uint8_t>(p.mode));
  EXPECT_NEAR(s.packets_per_second(), p.expected_pps, 0.5);
  ASSERT_EQ(s.packet_size(), mi.packet_size);
  std::vector<std::byte> buf(s.packet_size());
  int prev_az = -1;
  std::size_t returns = 0, units = 0;
  for (std::uint64_t k = 0; k < 300; ++k) {
    s.render_packet(k, buf);
    ASSERT_EQ(hesai::check_packet(buf, p.model), PacketStatus::kOk) << "packet " << k;
    const auto info = hesai::read_packet_info(buf, p.model);
    ASSERT_TRUE(info);
    EXPECT_EQ(info->return_mode, static_cast<std::uint8_t>(p.mode));
    EXPECT_EQ(info->returns, echoes);
    ASSERT_TRUE(info->tail_time_ns) << "UTC date/time in the tail";
    EXPECT_EQ(*info->tail_time_ns, s.tail_time(k) / 1000 * 1000);  // µs resolution
    // The decoder's packet time (tail + its firing offset) is the packet's first firing.
    // (Within the µs the tail carries; integers: doubles of 1.7e18 ns have a 256 ns step.)
    const Nanos err = *info->tail_time_ns + hesai::first_firing_offset_ns(p.model, echoes) - s.first_firing(k);
    EXPECT_GT(err, -1000);
    EXPECT_LE(err, 0);
    const auto* b = reinterpret_cast<const std::uint8_t*>(buf.data());
    if (p.model == Model::kPandarXT32) {
      EXPECT_EQ(b[offsetof(hesai::HeaderXT, protocol_major)], 6);
      EXPECT_EQ(b[offsetof(hesai::HeaderXT, return_num)], echoes);
      EXPECT_EQ(hesai::le32(b + offsetof(hesai::PacketXT32, udp_sequence)), k);
      EXPECT_EQ(hesai::le16(b + offsetof(hesai::PacketXT32, tail) + offsetof(hesai::TailXT32, motor_speed)), p.rpm);
    } else {
      EXPECT_EQ(hesai::le16(b + offsetof(hesai::Packet40P, tail) + offsetof(hesai::Tail40P, motor_speed)), p.rpm);
    }
    for (int blk = 0; blk < mi.blocks; ++blk) {
      const std::uint8_t* block = b + mi.first_block + static_cast<std::size_t>(blk) * mi.block_size;
      const int az = hesai::le16(block + mi.block_azimuth);
      if (blk % echoes == 1) {  // the second echo block of a dual group: same azimuth and echo
        EXPECT_EQ(std::memcmp(block, block - mi.block_size, mi.block_size), 0);
        continue;
      }
      if (prev_az >= 0) {
        EXPECT_NEAR((az - prev_az + 36000) % 36000, p.az_step, 1.0) << "packet " << k;
      }
      prev_az = az;
      for (int c = 0; c < mi.channels; ++c, ++units)
        returns += hesai::le16(block + mi.block_units + static_cast<std::size_t>(c) * mi.unit_size) != 0 ? 1 : 0;
    }
  }
  EXPECT_GT(returns, units / 2);
  EXPECT_LT(returns, units);
}

TEST_P(SyntheticHesaiModels, RoundTripThroughDecoderReproducesScene) {
  const Case& p = GetParam();
  const auto s = make(90.0);
  const auto& mi = hesai::model_info(p.model);
  const int echoes = hesai::return_count(static_cast<std::uint8_t>(p.mode));
  hesai::DecoderConfig dc;
  dc.model = p.model;
  dc.returns = echoes == 2 ? hesai::ReturnSelection::kDual : hesai::ReturnSelection::kStrongest;
  dc.emit_partial_scans = true;
  hesai::Decoder dec(dc);
  std::vector<int> channel_of_ring(static_cast<std::size_t>(mi.channels));
  for (int c = 1; c <= mi.channels; ++c) channel_of_ring[dec.ring_of_channel(c)] = c - 1;

  // 3.5 revolutions from 90°: ends near 270°, far from the cut, so no point waits for a next scan.
  const auto packets = static_cast<std::uint64_t>(3.5 * 60.0 / p.rpm * s.packets_per_second());
  std::vector<std::byte> buf(s.packet_size());
  std::vector<Scan> scans;
  std::size_t expected = 0;
  for (std::uint64_t k = 0; k < packets; ++k) {
    s.render_packet(k, buf);
    const auto* b = reinterpret_cast<const std::uint8_t*>(buf.data());
    for (int blk = 0; blk < mi.blocks; blk += echoes)
      for (int c = 0; c < mi.channels; ++c)
        expected += hesai::le16(b + mi.first_block + static_cast<std::size_t>(blk) * mi.block_size + mi.block_units +
                                static_cast<std::size_t>(c) * mi.unit_size) != 0 ? 1 : 0;
    const auto info = hesai::read_packet_info(buf, p.model);
    const Nanos stamp = *info->tail_time_ns + dec.first_firing_offset_ns(echoes);
    if (auto scan = dec.push(PacketView{buf, stamp, hesai::kDataPort}, stamp)) scans.push_back(std::move(*scan));
    ASSERT_EQ(dec.last_status(), PacketStatus::kOk);
  }
  if (auto last = dec.flush()) scans.push_back(std::move(*last));
  ASSERT_EQ(scans.size(), 4u) << "partial, complete, complete, partial";

  std::size_t points = 0, off_exact = 0, off_decoder = 0, wrong_refl = 0;
  double worst_exact = 0, worst_decoder = 0;
  for (const Scan& scan : scans) {
    for (const PointXYZIRT& pt : scan.points) {
      ++points;
      const int ch = channel_of_ring[pt.ring];
      const double x = static_cast<double>(pt.x), y = static_cast<double>(pt.y), z = static_cast<double>(pt.z);
      const double r = std::sqrt(x * x + y * y + z * z);
      // The sensor fired the channel firing_rotation later than the block azimuth says.
      const double delta = s.firing_rotation_deg(ch) * kDegToRad;
      const Vec3 exact{x * std::cos(delta) + y * std::sin(delta), -x * std::sin(delta) + y * std::cos(delta), z};
      const double tol = 0.002 + r * (0.005 * kDegToRad + 2e-6) + 2e-4;  // 4 mm / 2, azimuth 0.01° / 2, float
      const double d_exact = s.scene().distance_to_surface(exact);
      worst_exact = std::max(worst_exact, d_exact / tol);
      off_exact += d_exact > tol ? 1 : 0;
      const double tol_dec = tol + r * std::abs(delta);
      const double d_dec = s.scene().distance_to_surface({x, y, z});
      worst_decoder = std::max(worst_decoder, d_dec / tol_dec);
      off_decoder += d_dec > tol_dec ? 1 : 0;
      bool match = false;
      for (const Surface& surf : s.scene().surfaces()) {
        if (surf.reflectivity != static_cast<std::uint8_t>(pt.intensity)) continue;
        Scene one;
        one.add(surf);
        match = match || one.distance_to_surface(exact) <= tol;
      }
      wrong_refl += match ? 0 : 1;
    }
  }
  EXPECT_EQ(points, expected);
  EXPECT_EQ(off_exact, 0u) << "worst distance / tolerance " << worst_exact;
  EXPECT_EQ(off_decoder, 0u) << "worst distance / tolerance " << worst_decoder;
  EXPECT_EQ(wrong_refl, 0u);

  // The complete scans: one revolution apart, the same size, starting at the cut (0°).
  const double rev_ns = 60e9 / p.rpm;
  EXPECT_NEAR(static_cast<double>(scans[2].stamp - scans[1].stamp), rev_ns, s.packet_period_ns());
  EXPECT_NEAR(static_cast<double>(scans[1].points.size()), static_cast<double>(scans[2].points.size()),
              0.01 * static_cast<double>(scans[1].points.size()));
  const double az = s.azimuth_deg_at(scans[1].stamp);
  EXPECT_LT(std::min(az, 360.0 - az), 6.0);  // the cut window reaches up to the largest azimuth offset
}

INSTANTIATE_TEST_SUITE_P(
    Models, SyntheticHesaiModels,
    testing::Values(Case{Model::kPandar40P, ReturnMode::kStrongest, 600, 1799.86, 20},
                    Case{Model::kPandar40P, ReturnMode::kLastStrongest, 600, 3599.7, 20},
                    Case{Model::kPandar40P, ReturnMode::kLast, 1200, 1799.86, 40},
                    Case{Model::kPandarXT32, ReturnMode::kStrongest, 600, 2500, 18},
                    Case{Model::kPandarXT32, ReturnMode::kLastStrongest, 300, 5000, 9},
                    Case{Model::kPandarXT32, ReturnMode::kStrongest, 1200, 2500, 36}),
    [](const auto& i) {
      return std::string(hesai::model_info(i.param.model).name) + "_" + std::to_string(int(i.param.mode)) + "_" +
             std::to_string(int(i.param.rpm));
    });

// The driver's path: registry decoder, packet time from the tail, scans at the rotation rate.
TEST(SyntheticHesai, DriverPathSeesHostClockTimeAndScansAt10Hz) {
  for (const char* model : {"Pandar40P", "PandarXT32"}) {
    SCOPED_TRACE(model);
    SyntheticHesaiConfig c;
    c.model = *hesai::model_from_name(model);
    c.start_ns = kStart;
    c.start_azimuth_deg = 300.0;  // the rotor passes the cut window's start before the first cut
    SyntheticHesai s(c, Scene::standard());
    DecoderOptions o;
    o.model = model;
    auto dec = make_decoder(o);
    std::vector<Nanos> stamps;
    Nanos prev_t = 0, prev_send = 0;
    const auto packets = static_cast<int>(std::lround(0.35 * s.packets_per_second()));
    for (int k = 0; k < packets; ++k) {
      const SyntheticPacket p = s.next();
      EXPECT_GE(p.time_ns, s.tail_time(static_cast<std::uint64_t>(k)));  // sent once complete
      EXPECT_GT(p.time_ns, prev_send);
      prev_send = p.time_ns;
      const auto t = dec->packet_time(p.bytes);
      ASSERT_EQ(t.kind, SensorTime::Kind::kAbsoluteNs);
      const Nanos err = t.value - s.first_firing(static_cast<std::uint64_t>(k));
      EXPECT_GT(err, -1000);
      EXPECT_LE(err, 0);
      EXPECT_GT(t.value, prev_t);
      prev_t = t.value;
      if (auto scan = dec->push(PacketView{p.bytes, p.time_ns, hesai::kDataPort}, t.value)) stamps.push_back(scan->stamp);
    }
    ASSERT_EQ(stamps.size(), 3u);  // 3.5 revolutions from 300°: a partial scan (dropped), then 3 complete
    for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_NEAR(static_cast<double>(stamps[i] - stamps[i - 1]), 1e8, 1e6);
    EXPECT_EQ(dec->counters().dropped(), 0u);
  }
}

TEST(SyntheticHesai, RejectsSpeedsTheSensorDoesNotRun) {
  SyntheticHesaiConfig c;
  c.rpm = 300;  // the Pandar40P runs at 10 or 20 Hz only
  EXPECT_THROW(SyntheticHesai(c, Scene::standard()), std::invalid_argument);
  c.model = Model::kPandarXT32;
  EXPECT_NO_THROW(SyntheticHesai(c, Scene::standard()));
  c.rpm = 900;
  EXPECT_THROW(SyntheticHesai(c, Scene::standard()), std::invalid_argument);
  EXPECT_FALSE(hesai_rpm_error(Model::kPandar40P, 1200).size());
  c.rpm = 600;
  c.udp_sequence = true;  // only the 40P has it
  EXPECT_THROW(SyntheticHesai(c, Scene::standard()), std::invalid_argument);
  c.udp_sequence = false;
  c.calibration = hesai::default_calibration(Model::kPandar40P);  // 40 channels for a 32-channel sensor
  EXPECT_THROW(SyntheticHesai(c, Scene::standard()), std::invalid_argument);
}

TEST(SyntheticHesai, Pandar40PWithUdpSequence) {
  SyntheticHesaiConfig c;
  c.udp_sequence = true;
  c.start_ns = kStart;
  SyntheticHesai s(c, Scene::standard());
  ASSERT_EQ(s.packet_size(), hesai::k40PPacketSizeWithSequence);
  std::vector<std::byte> buf(s.packet_size());
  s.render_packet(7, buf);
  EXPECT_EQ(hesai::check_packet(buf, Model::kPandar40P), PacketStatus::kOk);
  EXPECT_EQ(hesai::le32(reinterpret_cast<const std::uint8_t*>(buf.data()) + sizeof(hesai::Packet40P)), 7u);
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
