// Synthetic Hesai sensor: scene -> Pandar40P / PandarXT32 data packets (see synthetic_hesai.hpp).
#include "sensor_rig/lidar/mock/synthetic_hesai.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "sensor_rig/common/angles.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::lidar::mock {
namespace {
constexpr std::uint8_t kFactoryInfo = 0x42;
constexpr std::uint8_t kXtProtocolMajor = 6, kXtProtocolMinor = 1;
constexpr std::uint8_t kXtDistanceUnitMm = 4;

// Civil date of a day count since 1970-01-01 (proleptic Gregorian; the inverse of the decoder's
// days_from_civil).
struct Civil {
  std::int64_t y;
  unsigned m, d;
};
Civil civil_from_days(std::int64_t z) noexcept {
  z += 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<unsigned>(z - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  const unsigned d = doy - (153 * mp + 2) / 5 + 1;
  const unsigned m = mp < 10 ? mp + 3 : mp - 9;
  return {static_cast<std::int64_t>(yoe) + era * 400 + (m <= 2 ? 1 : 0), m, d};
}

// UTC date/time (year - year_offset, month, day, hour, minute, second) and µs within the second.
void put_utc(std::uint8_t* utc, std::uint8_t* us_field, Nanos t, int year_offset) noexcept {
  const Nanos sec = floor_div(t, kSec);
  const Nanos days = floor_div(sec, 86400);
  const Nanos sod = sec - days * 86400;
  const Civil c = civil_from_days(days);
  utc[0] = static_cast<std::uint8_t>(std::clamp<std::int64_t>(c.y - year_offset, 0, 255));
  utc[1] = static_cast<std::uint8_t>(c.m);
  utc[2] = static_cast<std::uint8_t>(c.d);
  utc[3] = static_cast<std::uint8_t>(sod / 3600);
  utc[4] = static_cast<std::uint8_t>(sod / 60 % 60);
  utc[5] = static_cast<std::uint8_t>(sod % 60);
  hesai::put_le32(us_field, static_cast<std::uint32_t>((t - sec * kSec) / 1000));
}

}  // namespace

std::string hesai_rpm_error(hesai::Model m, double rpm) {
  const bool xt = m == hesai::Model::kPandarXT32;
  if (rpm == 600.0 || rpm == 1200.0 || (xt && rpm == 300.0)) return {};
  return std::string(hesai::model_info(m).name) + " spins at " + (xt ? "300, 600 or 1200" : "600 or 1200") +
         " rpm, not " + std::to_string(rpm);
}

SyntheticHesai::SyntheticHesai(SyntheticHesaiConfig config, Scene scene)
    : config_(std::move(config)), scene_(std::move(scene)), mi_(&hesai::model_info(config_.model)) {
  if (const auto e = hesai_rpm_error(config_.model, config_.rpm); !e.empty()) throw std::invalid_argument(e);
  const hesai::Calibration cal = config_.calibration ? *config_.calibration : hesai::default_calibration(config_.model);
  const hesai::FiringTimes fire =
      config_.firing_times ? *config_.firing_times : hesai::default_firing_times(config_.model);
  const auto n = static_cast<std::size_t>(mi_->channels);
  if (cal.channels.size() != n || fire.us.size() != n) {
    throw std::invalid_argument("synthetic " + std::string(mi_->name) + ": calibration needs " + std::to_string(n) +
                                " channels");
  }
  if (config_.udp_sequence && config_.model != hesai::Model::kPandar40P)
    throw std::invalid_argument("synthetic Hesai: only the Pandar40P has the optional UDP sequence");
  for (std::size_t c = 0; c < n; ++c) {
    const double el = cal.channels[c].elevation_deg * kRadPerDeg;
    channels_.push_back(Channel{std::sin(el), std::cos(el), cal.channels[c].azimuth_deg, std::llround(fire.us[c] * 1000.0)});
  }
  const auto [lo, hi] = std::minmax_element(channels_.begin(), channels_.end(),
                                            [](const Channel& a, const Channel& b) { return a.fire_ns < b.fire_ns; });
  min_fire_ns_ = lo->fire_ns;
  max_fire_ns_ = hi->fire_ns;
  echoes_ = hesai::return_count(static_cast<std::uint8_t>(config_.return_mode));
  if (echoes_ == 0) throw std::invalid_argument("synthetic Hesai: unknown return mode");
  groups_ = mi_->blocks / echoes_;
  packet_size_ = config_.udp_sequence ? mi_->packet_size_alt : mi_->packet_size;
  deg_per_ns_ = config_.rpm * 360.0 / 60e9;
  buf_.resize(packet_size_);
}

double SyntheticHesai::packet_period_ns() const noexcept {
  return static_cast<double>(groups_) * static_cast<double>(mi_->group_period_ns);
}

Nanos SyntheticHesai::group_time(std::uint64_t group) const noexcept {
  return config_.start_ns + static_cast<Nanos>(group) * mi_->group_period_ns;
}

Nanos SyntheticHesai::tail_time(std::uint64_t packet) const noexcept {
  return group_time((packet + 1) * static_cast<std::uint64_t>(groups_) - 1) - mi_->tail_to_last_group_ns;
}

Nanos SyntheticHesai::first_firing(std::uint64_t packet) const noexcept {
  return group_time(packet * static_cast<std::uint64_t>(groups_)) + min_fire_ns_;
}

double SyntheticHesai::azimuth_deg_at(Nanos t) const noexcept {
  const double a = std::fmod(config_.start_azimuth_deg + deg_per_ns_ * static_cast<double>(t - config_.start_ns), 360.0);
  return a < 0 ? a + 360.0 : a;
}

double SyntheticHesai::firing_rotation_deg(int channel) const noexcept {
  if (channel < 0 || channel >= mi_->channels) return 0.0;
  return deg_per_ns_ * static_cast<double>(channels_[static_cast<std::size_t>(channel)].fire_ns);
}

void SyntheticHesai::render_packet(std::uint64_t index, std::span<std::byte> out) const noexcept {
  if (out.size() < packet_size_) return;
  auto* p = reinterpret_cast<std::uint8_t*>(out.data());
  std::memset(p, 0, packet_size_);
  const bool xt = config_.model == hesai::Model::kPandarXT32;
  if (xt) {
    p[offsetof(hesai::HeaderXT, sop)] = 0xEE;
    p[offsetof(hesai::HeaderXT, sop) + 1] = 0xFF;
    p[offsetof(hesai::HeaderXT, protocol_major)] = kXtProtocolMajor;
    p[offsetof(hesai::HeaderXT, protocol_minor)] = kXtProtocolMinor;
    p[offsetof(hesai::HeaderXT, laser_num)] = static_cast<std::uint8_t>(mi_->channels);
    p[offsetof(hesai::HeaderXT, block_num)] = static_cast<std::uint8_t>(mi_->blocks);
    p[offsetof(hesai::HeaderXT, dis_unit)] = kXtDistanceUnitMm;
    p[offsetof(hesai::HeaderXT, return_num)] = static_cast<std::uint8_t>(echoes_);
  }
  const double unit_m = xt ? kXtDistanceUnitMm * 1e-3 : mi_->distance_unit_m;
  for (int g = 0; g < groups_; ++g) {
    const Nanos tg = group_time(index * static_cast<std::uint64_t>(groups_) + static_cast<std::uint64_t>(g));
    std::uint8_t* blk = p + mi_->first_block + static_cast<std::size_t>(g * echoes_) * mi_->block_size;
    if (!xt) {
      blk[0] = 0xFF;
      blk[1] = 0xEE;
    }
    hesai::put_le16(blk + mi_->block_azimuth,
                    static_cast<std::uint16_t>(std::lround(azimuth_deg_at(tg) * 100.0) % hesai::kAzimuthCount));
    std::uint8_t* units = blk + mi_->block_units;
    for (std::size_t c = 0; c < channels_.size(); ++c) {
      const Channel& ch = channels_[c];
      const double a = (azimuth_deg_at(tg + ch.fire_ns) + ch.azimuth_offset_deg) * kRadPerDeg;
      const Vec3 dir{ch.cos_el * std::cos(a), -ch.cos_el * std::sin(a), ch.sin_el};
      const auto hit = scene_.cast({0, 0, 0}, dir, config_.max_range_m);
      if (!hit) continue;
      const double counts = std::round(hit->range / unit_m);
      if (counts < 1.0 || counts > 65535.0) continue;
      std::uint8_t* u = units + c * mi_->unit_size;
      hesai::put_le16(u, static_cast<std::uint16_t>(counts));
      u[2] = hit->reflectivity;
    }
    if (echoes_ == 2) {  // one echo: it is both the last and the strongest
      std::memcpy(blk + mi_->block_size, blk, mi_->block_size);
    }
  }
  const Nanos tail = tail_time(index);
  p[mi_->tail_return_mode] = static_cast<std::uint8_t>(config_.return_mode);
  put_utc(p + mi_->tail_utc, p + mi_->tail_timestamp, tail, mi_->year_offset);
  const auto rpm = static_cast<std::uint16_t>(config_.rpm);
  if (xt) {
    hesai::put_le16(p + offsetof(hesai::PacketXT32, tail) + offsetof(hesai::TailXT32, motor_speed), rpm);
    p[offsetof(hesai::PacketXT32, tail) + offsetof(hesai::TailXT32, factory_info)] = kFactoryInfo;
    hesai::put_le32(p + offsetof(hesai::PacketXT32, udp_sequence), static_cast<std::uint32_t>(index));
  } else {
    hesai::put_le16(p + offsetof(hesai::Packet40P, tail) + offsetof(hesai::Tail40P, motor_speed), rpm);
    p[offsetof(hesai::Packet40P, tail) + offsetof(hesai::Tail40P, factory_info)] = kFactoryInfo;
    if (config_.udp_sequence) hesai::put_le32(p + sizeof(hesai::Packet40P), static_cast<std::uint32_t>(index));
  }
}

Nanos SyntheticHesai::complete_time(std::uint64_t packet) const noexcept {
  const std::uint64_t last_group = (packet + 1) * static_cast<std::uint64_t>(groups_) - 1;
  return std::max(tail_time(packet), group_time(last_group) + max_fire_ns_);
}

Nanos SyntheticHesai::first_packet_offset_ns() const noexcept { return complete_time(0) - config_.start_ns; }

UnitRule SyntheticHesai::unit_rule() const noexcept {
  // The decoder's window for cut angle 0: from the block azimuth where the channel with the largest
  // offset reaches the cut to the one where the smallest has passed it (offsets rounded away from 0).
  long off_min = 0, off_max = 0;
  for (std::size_t c = 0; c < channels_.size(); ++c) {
    const double v = channels_[c].azimuth_offset_deg * 100.0;
    const long o = static_cast<long>(v < 0 ? std::floor(v) : std::ceil(v));
    off_min = c == 0 ? o : std::min(off_min, o);
    off_max = c == 0 ? o : std::max(off_max, o);
  }
  const auto norm = [](long v) { return static_cast<int>(((v % hesai::kAzimuthCount) + hesai::kAzimuthCount) % hesai::kAzimuthCount); };
  return {UnitRule::Kind::kAzimuthWindow, norm(-off_max), norm(-off_min)};
}

SyntheticPacket SyntheticHesai::next() {
  render_packet(next_, buf_);
  const Nanos done = complete_time(next_);
  SyntheticPacket out{done, buf_, false, {}};
  PacketTruth& t = out.truth;
  t.data = true;
  t.index = next_;
  t.acq_ns = first_firing(next_);
  // The clock as the packet carries it: the tail's µs, back to the first firing (the decoder's packet_time).
  const Nanos tail = tail_time(next_);
  t.dev_ns = tail - (tail % 1000 + 1000) % 1000 + (t.acq_ns - tail);
  t.rotor_deg = azimuth_deg_at(group_time(next_ * static_cast<std::uint64_t>(groups_)));
  t.groups = static_cast<std::uint8_t>(groups_);
  for (int g = 0; g < groups_; ++g) {
    const Nanos tg = group_time(next_ * static_cast<std::uint64_t>(groups_) + static_cast<std::uint64_t>(g));
    t.group_ns[static_cast<std::size_t>(g)] = tg + min_fire_ns_;
    t.group_az[static_cast<std::size_t>(g)] =
        static_cast<std::uint16_t>(std::lround(azimuth_deg_at(tg) * 100.0) % hesai::kAzimuthCount);
  }
  ++next_;
  return out;
}

}  // namespace sensor_rig::lidar::mock
