#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "sensor_rig/common/angles.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr Nanos kHourNs = 3'600'000'000'000LL;

std::uint32_t sensor_time_us(Nanos t) noexcept {
  return static_cast<std::uint32_t>(floor_mod(t, kHourNs) / 1000);
}

}  // namespace

SyntheticVelodyne::SyntheticVelodyne(SyntheticConfig config, Scene scene)
    : config_(std::move(config)), scene_(std::move(scene)), info_(velodyne::model_info(config_.model)) {
  if (!(config_.rpm >= 60.0 && config_.rpm <= 1200.0)) {
    throw std::invalid_argument("synthetic sensor: rpm must be in 60..1200, got " + std::to_string(config_.rpm));
  }
  if (config_.position_period_ns < 0) throw std::invalid_argument("synthetic sensor: negative position period");
  const velodyne::Calibration cal = velodyne::validate_for_model(
      config_.calibration ? *config_.calibration : velodyne::default_calibration(config_.model), config_.model);
  resolution_m_ = cal.distance_resolution_m;
  for (const velodyne::LaserCorrection& c : cal.lasers) {
    lasers_.push_back(Laser{std::sin(c.vert_correction), std::cos(c.vert_correction), c.rot_correction,
                            c.dist_correction, c.vert_offset_correction, c.horiz_offset_correction});
  }
  for (int c = 0; c < static_cast<int>(velodyne::kChannelsPerBlock); ++c) {
    channel_ns_[static_cast<std::size_t>(c)] = velodyne::channel_offset_ns(config_.model, c);
    channel_laser_[static_cast<std::size_t>(c)] = velodyne::channel_laser(config_.model, c);
  }
  max_range_m_ = info_.max_range_m;
  dual_ = config_.return_mode == velodyne::ReturnMode::kDual;
  block_ns_ = info_.block_us * 1000.0;
  const double firings = dual_ ? velodyne::kBlocksPerPacket / 2.0 : static_cast<double>(velodyne::kBlocksPerPacket);
  packet_period_ns_ = firings * block_ns_;
  deg_per_ns_ = config_.rpm * 360.0 / 60e9;
}

Nanos SyntheticVelodyne::data_packet_time(std::uint64_t index) const noexcept {
  return config_.start_ns + std::llround(static_cast<double>(index) * packet_period_ns_);
}

double SyntheticVelodyne::azimuth_deg_at(Nanos t) const noexcept {
  const double a = std::fmod(config_.start_azimuth_deg + deg_per_ns_ * static_cast<double>(t - config_.start_ns), 360.0);
  return a < 0 ? a + 360.0 : a;
}

std::uint16_t SyntheticVelodyne::raw_distance(const Laser& l, double azimuth_rad, std::uint8_t& intensity) const noexcept {
  // The ROS velodyne / VeloView point model the decoder inverts:
  //   p = O + (raw·resolution + dist_correction)·D, r = azimuth - rot_correction,
  //   D = (cos v cos r, -cos v sin r, sin v), O from the vertical and horizontal offsets.
  const double r = azimuth_rad - l.rot_rad;
  const double cr = std::cos(r), sr = std::sin(r);
  const Vec3 dir{l.cos_v * cr, -l.cos_v * sr, l.sin_v};
  const Vec3 origin{-l.vert_offset * l.sin_v * cr + l.horiz_offset * sr,
                    l.vert_offset * l.sin_v * sr + l.horiz_offset * cr, l.vert_offset * l.cos_v};
  intensity = 0;
  const auto hit = scene_.cast(origin, dir, max_range_m_);
  if (!hit) return 0;
  const double counts = std::round((hit->range - l.dist_correction) / resolution_m_);
  if (counts < 1.0 || counts > 65535.0) return 0;  // 0 = no return on the wire
  intensity = hit->reflectivity;
  return static_cast<std::uint16_t>(counts);
}

Nanos SyntheticVelodyne::block_time(Nanos t0, std::size_t f) const noexcept {
  return config_.start_ns + std::llround(static_cast<double>(t0 - config_.start_ns) + static_cast<double>(f) * block_ns_);
}

std::uint16_t SyntheticVelodyne::azimuth_raw(Nanos t) const noexcept {
  return static_cast<std::uint16_t>(std::lround(azimuth_deg_at(t) * 100.0) % 36000);
}

void SyntheticVelodyne::render_data_packet(std::uint64_t index,
                                           std::span<std::byte, velodyne::kDataPacketSize> out) const noexcept {
  velodyne::RawDataPacket p{};
  const Nanos t0 = data_packet_time(index);
  const std::size_t firings = dual_ ? velodyne::kBlocksPerPacket / 2 : velodyne::kBlocksPerPacket;
  for (std::size_t f = 0; f < firings; ++f) {
    const Nanos t_block_ns = block_time(t0, f);
    const std::uint16_t az_raw = azimuth_raw(t_block_ns);
    velodyne::RawBlock block{};
    block.flag[0] = 0xFF;
    block.flag[1] = 0xEE;
    velodyne::put_le16(block.azimuth, az_raw);
    for (std::size_t c = 0; c < velodyne::kChannelsPerBlock; ++c) {
      const Nanos t_fire = t_block_ns + channel_ns_[c];
      const auto laser = static_cast<std::size_t>(channel_laser_[c]);
      std::uint8_t intensity = 0;
      const std::uint16_t d = raw_distance(lasers_[laser], azimuth_deg_at(t_fire) * kRadPerDeg, intensity);
      velodyne::put_le16(block.channels[c].distance, d);
      block.channels[c].intensity = intensity;
    }
    // A scene has one echo per beam: in dual mode it is both the last and the strongest return.
    if (dual_) {
      p.blocks[2 * f] = block;
      p.blocks[2 * f + 1] = block;
    } else {
      p.blocks[f] = block;
    }
  }
  velodyne::put_le32(p.timestamp, sensor_time_us(t0));
  p.return_mode = static_cast<std::uint8_t>(config_.return_mode);
  p.product_id = static_cast<std::uint8_t>(info_.product_id);
  std::memcpy(out.data(), &p, sizeof p);
}

void SyntheticVelodyne::render_position_packet(Nanos t,
                                               std::span<std::byte, velodyne::kPositionPacketSize> out) const {
  const Nanos whole_second = t - floor_mod(t, kSec);
  const std::string rmc = velodyne::format_rmc({whole_second, config_.gps_fix_valid});
  velodyne::encode_position_packet(sensor_time_us(t), config_.pps, rmc, out);
}

SyntheticPacket SyntheticVelodyne::next() {
  const Nanos data_t = data_packet_time(next_data_);
  if (config_.position_period_ns > 0) {
    const Nanos pos_t = config_.start_ns + static_cast<Nanos>(next_position_) * config_.position_period_ns;
    if (pos_t <= data_t) {
      render_position_packet(pos_t, pos_buf_);
      ++next_position_;
      return SyntheticPacket{pos_t, pos_buf_, true, {}};
    }
  }
  render_data_packet(next_data_, data_buf_);
  SyntheticPacket out{data_t, data_buf_, false, {}};
  PacketTruth& t = out.truth;
  t.data = true;
  t.index = next_data_;
  t.acq_ns = data_t;
  t.dev_ns = static_cast<Nanos>(sensor_time_us(data_t)) * 1000;
  t.rotor_deg = azimuth_deg_at(data_t);
  t.groups = static_cast<std::uint8_t>(dual_ ? velodyne::kBlocksPerPacket / 2 : velodyne::kBlocksPerPacket);
  for (std::size_t f = 0; f < t.groups; ++f) {
    t.group_ns[f] = block_time(data_t, f);
    t.group_az[f] = azimuth_raw(t.group_ns[f]);
  }
  ++next_data_;
  return out;
}

}  // namespace sensor_rig::lidar::mock
