// Synthetic Ouster sensor: scene -> lidar packets of any profile (see synthetic_ouster.hpp).
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>

#include "sensor_rig/common/angles.hpp"
#include "sensor_rig/lidar/ouster/imu_packet.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr std::uint32_t kEncoderTicks = 90112;  // LEGACY encoder counts per revolution
constexpr std::uint32_t kLegacyColumnValid = 0xFFFFFFFFU;
constexpr std::uint16_t kColumnValid = 0x0001;
constexpr std::uint64_t kNearIr = 100;
constexpr double kSignalScale = 4000.0;  // photons of a reflectivity-1 target at 1 m

// Column header offsets (the ones ouster/packet.cpp reads): timestamp u64 at 0, measurement id u16
// at 8; LEGACY: frame id u16 at 10, encoder count u32 at 12, status u32 in the column footer;
// others: status u16 at 10.
constexpr std::size_t kTimestampOffset = 0;
constexpr std::size_t kMeasurementIdOffset = 8;
constexpr std::size_t kLegacyFrameIdOffset = 10;
constexpr std::size_t kLegacyEncoderOffset = 12;
constexpr std::size_t kStatusOffset = 10;

void put_le(std::uint8_t* p, std::uint64_t v, std::size_t n) noexcept {
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>((v >> (8U * i)) & 0xFFU);
}

// Writes `v` (already in the field's units, i.e. shifted down by its upshift) into the field at
// `base`, leaving the other bits of the bytes it shares untouched: the inverse of FieldReader.
void put_field(std::uint8_t* base, const ouster::FieldSpec& f, std::uint64_t v) noexcept {
  const auto r = ouster::FieldReader::from(f);
  if (r.nbytes == 0) return;
  std::uint8_t* p = base + r.byte_offset;
  std::uint64_t w = 0;
  for (std::uint8_t i = 0; i < r.nbytes; ++i) w |= static_cast<std::uint64_t>(p[i]) << (8U * i);
  w &= ~(r.mask << r.shift);
  w |= (v & r.mask) << r.shift;
  put_le(p, w, r.nbytes);
}

std::uint64_t max_of(const ouster::FieldSpec& f) noexcept {
  return f.width >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << f.width) - 1;
}

bool in_window(int mid, const ouster::SensorMetadata& m) noexcept {
  const int a = m.column_window_first, b = m.column_window_last;
  return a <= b ? (mid >= a && mid <= b) : (mid >= a || mid <= b);
}

std::uint64_t serial_number(const std::string& s) noexcept {
  std::uint64_t v = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return 0;
    v = v * 10 + static_cast<std::uint64_t>(c - '0');
  }
  return v & ((std::uint64_t{1} << 40) - 1);  // the header's prod_sn is 40 bits
}

}  // namespace

SyntheticOuster::SyntheticOuster(SyntheticOusterConfig config, Scene scene)
    : config_(std::move(config)), scene_(std::move(scene)) {
  const auto& m = config_.metadata;
  if (m.pixels_per_column <= 0 || m.columns_per_frame <= 0 || m.columns_per_packet <= 0 ||
      !(m.frames_per_second > 0.0) || m.beam_altitude_deg.size() != static_cast<std::size_t>(m.pixels_per_column) ||
      m.beam_azimuth_deg.size() != static_cast<std::size_t>(m.pixels_per_column)) {
    throw std::invalid_argument("synthetic Ouster: metadata has no usable data format or beam angles");
  }
  if (m.columns_per_frame % m.columns_per_packet != 0)
    throw std::invalid_argument("synthetic Ouster: columns_per_frame is not a multiple of columns_per_packet");
  if (config_.start_column < 0 || config_.start_column >= m.columns_per_frame ||
      config_.start_column % m.columns_per_packet != 0) {
    throw std::invalid_argument("synthetic Ouster: start column " + std::to_string(config_.start_column) +
                                " is not the first column of a packet in the frame");
  }
  if (!(config_.max_range_m > 0.0)) throw std::invalid_argument("synthetic Ouster: max range must be positive");
  layout_ = m.layout();  // throws std::invalid_argument on impossible sizes
  column_ns_ = m.column_period_ns();
  buf_.resize(layout_.packet_size);

  // ouster-sdk's projection (the decoder's XyzLut, in double): ray of column c, beam r.
  const auto width = static_cast<std::size_t>(m.columns_per_frame);
  const auto height = static_cast<std::size_t>(m.pixels_per_column);
  const auto& b = m.beam_to_lidar;
  const auto& t = m.lidar_to_sensor;
  const double bx = b[3], bz = b[11];
  const double d = bz != 0.0 ? std::hypot(bx, bz) : bx;
  rays_.resize(width * height);
  for (std::size_t c = 0; c < width; ++c) {
    const double e = 2.0 * std::numbers::pi * (1.0 - static_cast<double>(c) / static_cast<double>(width));
    for (std::size_t r = 0; r < height; ++r) {
      const double a = -m.beam_azimuth_deg[r] * kRadPerDeg;
      const double p = m.beam_altitude_deg[r] * kRadPerDeg;
      const double dir[3] = {std::cos(e + a) * std::cos(p), std::sin(e + a) * std::cos(p), std::sin(p)};
      const double off[3] = {bx * std::cos(e) - d * dir[0], bx * std::sin(e) - d * dir[1], bz - d * dir[2]};
      double rd[3], ro[3];
      for (std::size_t i = 0; i < 3; ++i) {
        rd[i] = t[4 * i] * dir[0] + t[4 * i + 1] * dir[1] + t[4 * i + 2] * dir[2];
        ro[i] = (t[4 * i] * off[0] + t[4 * i + 1] * off[1] + t[4 * i + 2] * off[2] + t[4 * i + 3]) * 1e-3;
      }
      const double n = std::sqrt(rd[0] * rd[0] + rd[1] * rd[1] + rd[2] * rd[2]);  // 1 for a rotation
      rays_[c * height + r] = Ray{{ro[0], ro[1], ro[2]}, {rd[0] / n, rd[1] / n, rd[2] / n}};
    }
  }
}

double SyntheticOuster::packets_per_second() const noexcept {
  return config_.metadata.frames_per_second * config_.metadata.columns_per_frame / config_.metadata.columns_per_packet;
}

Nanos SyntheticOuster::column_time(std::uint64_t column) const noexcept {
  return config_.start_ns + std::llround(static_cast<double>(column) * column_ns_);
}

Nanos SyntheticOuster::packet_time(std::uint64_t index) const noexcept {
  return column_time(index * layout_.columns_per_packet);
}

void SyntheticOuster::render_packet(std::uint64_t index, std::span<std::byte> out) const noexcept {
  if (out.size() < layout_.packet_size) return;
  auto* p = reinterpret_cast<std::uint8_t*>(out.data());
  std::memset(p, 0, layout_.packet_size);
  const auto& m = config_.metadata;
  const auto& spec = ouster::profile_spec(layout_.profile);
  const auto width = static_cast<std::uint64_t>(m.columns_per_frame);
  const std::uint64_t first = static_cast<std::uint64_t>(config_.start_column) + index * layout_.columns_per_packet;
  const auto frame = static_cast<std::uint32_t>(config_.first_frame_id + first / width);
  const bool legacy = layout_.header == ouster::HeaderType::kLegacy;
  if (!legacy) {
    const auto& h = ouster::header_spec(layout_.header);
    put_field(p, h.packet_type, ouster::kLidarPacketType);
    put_field(p, h.frame_id, frame);
    put_field(p, h.init_id, m.init_id);
    put_field(p, h.prod_sn, serial_number(m.prod_sn));
  }
  const auto& range = spec.field(ouster::Field::kRange);
  const std::uint64_t range_max = max_of(range);
  const double range_unit_mm = static_cast<double>(std::uint64_t{1} << range.upshift);
  const auto& nir = spec.field(ouster::Field::kNearIr);
  for (std::size_t c = 0; c < layout_.columns_per_packet; ++c) {
    const std::uint64_t k = first + c;
    const auto mid = static_cast<std::uint16_t>(k % width);
    std::uint8_t* col = p + layout_.column_offset(c);
    put_le(col + kTimestampOffset, static_cast<std::uint64_t>(column_time(index * layout_.columns_per_packet + c)), 8);
    put_le(col + kMeasurementIdOffset, mid, 2);
    const bool valid = in_window(mid, m);
    if (legacy) {
      put_le(col + kLegacyFrameIdOffset, static_cast<std::uint16_t>(frame), 2);
      put_le(col + kLegacyEncoderOffset, static_cast<std::uint64_t>(mid) * kEncoderTicks / width, 4);
      put_le(col + layout_.col_size - layout_.col_footer_size, valid ? kLegacyColumnValid : 0U, 4);
    } else {
      put_le(col + kStatusOffset, valid ? kColumnValid : 0U, 2);
    }
    if (!valid) continue;
    const Ray* rays = rays_.data() + static_cast<std::size_t>(mid) * layout_.pixels_per_column;
    for (std::size_t r = 0; r < layout_.pixels_per_column; ++r) {
      std::uint8_t* px = col + layout_.col_header_size + r * layout_.pixel_size;
      put_field(px, nir, kNearIr >> nir.upshift);
      const auto hit = scene_.cast(rays[r].origin, rays[r].dir, config_.max_range_m);
      if (!hit) continue;
      const auto counts = static_cast<std::uint64_t>(std::llround(hit->range * 1000.0 / range_unit_mm));
      if (counts == 0 || counts > range_max) continue;
      const double rm = std::max(hit->range, 1.0);
      const double signal = std::clamp(std::round(hit->reflectivity * kSignalScale / (rm * rm)), 1.0, 65535.0);
      put_field(px, range, counts);
      put_field(px, spec.field(ouster::Field::kReflectivity), hit->reflectivity);
      put_field(px, spec.field(ouster::Field::kSignal), static_cast<std::uint64_t>(signal));
    }
  }
}

Nanos SyntheticOuster::first_packet_offset_ns() const noexcept {
  return column_time(layout_.columns_per_packet) - config_.start_ns;
}

SyntheticPacket SyntheticOuster::next() {
  const Nanos lidar_time = column_time((next_ + 1) * layout_.columns_per_packet);
  if (config_.imu_period_ns > 0) {
    // Time order; a tie goes to the lidar packet (the stream's first packet is a lidar packet).
    const Nanos imu_time = column_time(layout_.columns_per_packet) + static_cast<Nanos>(imu_next_) * config_.imu_period_ns;
    if (imu_time < lidar_time) {
      ouster::ImuSample s;
      s.sys_ts_ns = s.accel_ts_ns = s.gyro_ts_ns = static_cast<std::uint64_t>(imu_time);
      s.accel_g = config_.imu_accel_g;
      s.gyro_dps = config_.imu_gyro_dps;
      imu_buf_.resize(ouster::kImuPacketSize);
      ouster::encode_imu_packet(s, std::span<std::byte, ouster::kImuPacketSize>(imu_buf_.data(), ouster::kImuPacketSize));
      ++imu_next_;
      return SyntheticPacket{imu_time, imu_buf_, true, {}};
    }
  }
  render_packet(next_, buf_);
  SyntheticPacket out{lidar_time, buf_, false, {}};  // lidar_time: the last column's period ends
  PacketTruth& t = out.truth;
  const auto width = static_cast<std::uint64_t>(config_.metadata.columns_per_frame);
  const std::uint64_t first = static_cast<std::uint64_t>(config_.start_column) + next_ * layout_.columns_per_packet;
  t.data = true;
  t.index = next_;
  t.acq_ns = column_time(next_ * layout_.columns_per_packet);
  t.dev_ns = t.acq_ns;  // a PTP-synced sensor: its column timestamps are vehicle time
  t.rotor_deg = 360.0 * static_cast<double>(first % width) / static_cast<double>(width);
  t.frame = static_cast<std::uint32_t>(config_.first_frame_id + first / width) & 0xFFFFU;
  ++next_;
  return out;
}

}  // namespace sensor_rig::lidar::mock
