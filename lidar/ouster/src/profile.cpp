// The field tables of every supported Ouster lidar UDP profile (bit positions from the sensor
// firmware manual; the same layout ouster-sdk's parsing.cpp encodes).
#include "sensor_rig/lidar/ouster/profile.hpp"

#include <stdexcept>
#include <string>

#include "profile_table.hpp"

namespace sensor_rig::lidar::ouster {
namespace {

// packet_type, frame_id, init_id, prod_sn, alert_flags, countdown_thermal_shutdown,
// countdown_shot_limiting, thermal_shutdown, shot_limiting
constexpr HeaderSpec kLegacyHeader{};  // LEGACY: frame id is in each column header
constexpr HeaderSpec kStandardHeader{bits(0, 16),   bits(16, 16),  bits(32, 24),  bits(56, 40), bits(96, 8),
                                     bits(128, 8),  bits(136, 8),  bits(144, 4),  bits(156, 4)};
constexpr HeaderSpec kFusaHeader{bits(0, 8),   bits(32, 32), bits(8, 24),  bits(88, 40), bits(64, 8),
                                 bits(128, 8), bits(136, 8), bits(144, 4), bits(156, 4)};

// Every table entry must fit its pixel: checked once at compile time.
constexpr bool tables_fit() {
  for (const auto& p : kProfileTable) {
    for (const auto& f : p.fields) {
      if (f.width > 32 || f.bit_offset + f.width > p.pixel_bytes * 8) return false;
    }
  }
  return true;
}
static_assert(tables_fit());

}  // namespace

const ProfileSpec& profile_spec(Profile p) noexcept {
  const auto i = static_cast<std::size_t>(p);
  return kProfileTable[i < kProfileCount ? i : 0];
}

std::span<const ProfileSpec> all_profiles() noexcept { return kProfileTable; }

std::optional<Profile> profile_from_name(std::string_view name) noexcept {
  for (const auto& p : kProfileTable)
    if (p.name == name) return p.profile;
  return std::nullopt;
}

std::string profile_names() {
  std::string s;
  for (const auto& p : kProfileTable) s += (s.empty() ? "" : ", ") + std::string(p.name);
  return s;
}

const HeaderSpec& header_spec(HeaderType h) noexcept {
  switch (h) {
    case HeaderType::kStandard:
      return kStandardHeader;
    case HeaderType::kFusa:
      return kFusaHeader;
    case HeaderType::kLegacy:
      break;
  }
  return kLegacyHeader;
}

HeaderType default_header_type(Profile p) noexcept {
  if (p == Profile::kLegacy) return HeaderType::kLegacy;
  return p == Profile::kFusaRng15Rfl8Nir8Dual ? HeaderType::kFusa : HeaderType::kStandard;
}

PacketLayout make_layout(Profile p, HeaderType h, std::size_t pixels_per_column, std::size_t columns_per_packet) {
  if (pixels_per_column == 0 || columns_per_packet == 0)
    throw std::invalid_argument("pixels_per_column and columns_per_packet must be positive");
  const bool legacy = p == Profile::kLegacy;
  if (legacy != (h == HeaderType::kLegacy))
    throw std::invalid_argument("the LEGACY profile and only it has no packet header");
  PacketLayout l;
  l.profile = p;
  l.header = h;
  l.pixels_per_column = pixels_per_column;
  l.columns_per_packet = columns_per_packet;
  l.packet_header_size = legacy ? 0 : 32;
  l.col_header_size = legacy ? 16 : 12;
  l.pixel_size = profile_spec(p).pixel_bytes;
  l.col_footer_size = legacy ? 4 : 0;
  l.packet_footer_size = legacy ? 0 : 32;
  // Bounded before multiplying: pixels_per_column and columns_per_packet come from metadata.
  if (pixels_per_column > kMaxPacketSize || columns_per_packet > kMaxPacketSize)
    throw std::invalid_argument("lidar packet would exceed 65535 bytes");
  l.col_size = l.col_header_size + pixels_per_column * l.pixel_size + l.col_footer_size;
  l.packet_size = l.packet_header_size + columns_per_packet * l.col_size + l.packet_footer_size;
  if (l.packet_size > kMaxPacketSize)
    throw std::invalid_argument("lidar packet of " + std::to_string(l.packet_size) + " bytes exceeds 65535 bytes");
  return l;
}

FieldReader FieldReader::from(const FieldSpec& f) noexcept {
  FieldReader r;
  if (f.width == 0) return r;
  r.byte_offset = static_cast<std::uint16_t>(f.bit_offset / 8);
  r.shift = static_cast<std::uint8_t>(f.bit_offset % 8);
  r.nbytes = static_cast<std::uint8_t>((r.shift + f.width + 7) / 8);
  r.upshift = f.upshift;
  r.mask = f.width >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << f.width) - 1;
  return r;
}

}  // namespace sensor_rig::lidar::ouster
