// Bounds-checked Ouster packet reads (see packet.hpp).
#include "sensor_rig/lidar/ouster/packet.hpp"

namespace sensor_rig::lidar::ouster {
namespace {

const std::uint8_t* bytes_of(std::span<const std::byte> b) noexcept {
  return reinterpret_cast<const std::uint8_t*>(b.data());
}

std::uint64_t le(const std::uint8_t* p, std::size_t n) noexcept {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8U * i);
  return v;
}

// Column header offsets: timestamp u64 at 0, measurement id u16 at 8; then LEGACY: frame id u16 at
// 10, encoder count u32 at 12, status u32 in the column footer; others: status u16 at 10.
constexpr std::size_t kTimestampOffset = 0;
constexpr std::size_t kMeasurementIdOffset = 8;
constexpr std::size_t kLegacyFrameIdOffset = 10;
constexpr std::size_t kLegacyEncoderOffset = 12;
constexpr std::size_t kStatusOffset = 10;

}  // namespace

PacketStatus check_packet(std::span<const std::byte> bytes, const PacketLayout& layout) noexcept {
  if (bytes.size() != layout.packet_size || layout.packet_size == 0) {
    return bytes.size() == kLegacyImuPacketSize ? PacketStatus::kNotData : PacketStatus::kWrongSize;
  }
  if (layout.header != HeaderType::kLegacy) {
    const auto type = FieldReader::from(header_spec(layout.header).packet_type).read(bytes_of(bytes));
    if (type != kLidarPacketType) return PacketStatus::kNotData;
  }
  return PacketStatus::kOk;
}

ColumnHeader column_header_at(const std::uint8_t* c, const PacketLayout& layout) noexcept {
  ColumnHeader h;
  h.timestamp_ns = le(c + kTimestampOffset, 8);
  h.measurement_id = static_cast<std::uint16_t>(le(c + kMeasurementIdOffset, 2));
  if (layout.header == HeaderType::kLegacy) {
    h.frame_id = static_cast<std::uint16_t>(le(c + kLegacyFrameIdOffset, 2));
    h.encoder_count = static_cast<std::uint32_t>(le(c + kLegacyEncoderOffset, 4));
    h.status = static_cast<std::uint32_t>(le(c + layout.col_size - layout.col_footer_size, 4));
  } else {
    h.status = static_cast<std::uint32_t>(le(c + kStatusOffset, 2));
  }
  return h;
}

std::uint32_t frame_id_at(const std::uint8_t* packet, const PacketLayout& layout) noexcept {
  if (layout.header == HeaderType::kLegacy) return static_cast<std::uint32_t>(le(packet + kLegacyFrameIdOffset, 2));
  return static_cast<std::uint32_t>(FieldReader::from(header_spec(layout.header).frame_id).read(packet));
}

std::optional<PacketHeader> read_packet_header(std::span<const std::byte> bytes, const PacketLayout& layout) noexcept {
  if (bytes.size() != layout.packet_size || layout.packet_size == 0) return std::nullopt;
  const auto* p = bytes_of(bytes);
  PacketHeader h;
  h.frame_id = frame_id_at(p, layout);
  if (layout.header == HeaderType::kLegacy) return h;
  const auto& s = header_spec(layout.header);
  const auto rd = [p](const FieldSpec& f) { return FieldReader::from(f).read(p); };
  h.packet_type = static_cast<std::uint16_t>(rd(s.packet_type));
  h.init_id = static_cast<std::uint32_t>(rd(s.init_id));
  h.prod_sn = rd(s.prod_sn);
  h.alert_flags = static_cast<std::uint8_t>(rd(s.alert_flags));
  h.countdown_thermal_shutdown = static_cast<std::uint8_t>(rd(s.countdown_thermal_shutdown));
  h.countdown_shot_limiting = static_cast<std::uint8_t>(rd(s.countdown_shot_limiting));
  h.thermal_shutdown = static_cast<std::uint8_t>(rd(s.thermal_shutdown));
  h.shot_limiting = static_cast<std::uint8_t>(rd(s.shot_limiting));
  return h;
}

std::optional<ColumnHeader> read_column_header(std::span<const std::byte> bytes, const PacketLayout& layout,
                                               std::size_t col) noexcept {
  if (bytes.size() != layout.packet_size || layout.packet_size == 0 || col >= layout.columns_per_packet)
    return std::nullopt;
  return column_header_at(bytes_of(bytes) + layout.column_offset(col), layout);
}

std::optional<std::uint64_t> read_field(std::span<const std::byte> bytes, const PacketLayout& layout,
                                        std::size_t col, std::size_t px, Field f) noexcept {
  if (bytes.size() != layout.packet_size || layout.packet_size == 0 || col >= layout.columns_per_packet ||
      px >= layout.pixels_per_column)
    return std::nullopt;
  const auto& spec = profile_spec(layout.profile);
  if (!spec.has(f)) return std::nullopt;
  const auto r = FieldReader::from(spec.field(f));
  const std::size_t off = layout.pixel_offset(col, px);
  if (off + r.end() > bytes.size()) return std::nullopt;
  return r.read(bytes_of(bytes) + off);
}

}  // namespace sensor_rig::lidar::ouster
