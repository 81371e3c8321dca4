#pragma once
// Ouster lidar UDP profiles as data (formats as data, as ouster-sdk's parsing.cpp): one field table
// per profile (bit offset, width, up-shift inside a pixel), one header table per header type, and
// the packet layout every size and offset is derived from. Sensor firmware manual, "Lidar Data
// Format" / "Lidar Data Packet Format"; all multi-byte fields are little-endian.
//
//   LEGACY:      16 columns x (16 B column header + pixels x 12 B + 4 B status), no packet header
//   others:      32 B packet header + columns x (12 B column header + pixels x pixel size) + 32 B footer
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace sensor_rig::lidar::ouster {

enum class Profile : std::uint8_t {
  kLegacy,
  kRng19Rfl8Sig16Nir16,      // single return, 12 B pixel
  kRng19Rfl8Sig16Nir16Dual,  // two returns, 16 B pixel
  kRng15Rfl8Nir8,            // low data rate, 4 B pixel, range in 8 mm units
  kRng15Rfl8Win8,            // low data rate with window byte
  kFiveWordPixel,            // two returns, 20 B pixel
  kFusaRng15Rfl8Nir8Dual,    // functional-safety header, two returns, 8 B pixel
  kRng15Rfl8Nir8Dual,        // two returns, 8 B pixel, standard header
};
inline constexpr std::size_t kProfileCount = 8;

// Where the packet header fields sit: none (LEGACY), standard (eUDP) or FuSa.
enum class HeaderType : std::uint8_t { kLegacy, kStandard, kFusa };

enum class Field : std::uint8_t {
  kRange,          // mm
  kFlags,
  kReflectivity,
  kSignal,         // photons
  kNearIr,
  kRange2,
  kFlags2,
  kReflectivity2,
  kSignal2,
  kWindow,
};
inline constexpr std::size_t kFieldCount = 10;

// A field inside a pixel: bits [bit_offset, bit_offset + width) of the little-endian pixel, then
// shifted up by `upshift` (low data rate profiles drop the low bits of range / near-IR).
// width 0: the profile does not carry the field.
struct FieldSpec {
  std::uint16_t bit_offset = 0;
  std::uint8_t width = 0;
  std::uint8_t upshift = 0;
};

struct ProfileSpec {
  Profile profile;
  std::string_view name;  // as in the metadata's udp_profile_lidar
  std::uint8_t pixel_bytes;
  std::uint8_t returns;  // 1 or 2
  std::array<FieldSpec, kFieldCount> fields;  // indexed by Field
  [[nodiscard]] const FieldSpec& field(Field f) const noexcept { return fields[static_cast<std::size_t>(f)]; }
  [[nodiscard]] bool has(Field f) const noexcept { return field(f).width != 0; }
};

// Packet header fields per header type (same bit notation, offsets from the packet start).
struct HeaderSpec {
  FieldSpec packet_type, frame_id, init_id, prod_sn, alert_flags, countdown_thermal_shutdown,
      countdown_shot_limiting, thermal_shutdown, shot_limiting;
};

const ProfileSpec& profile_spec(Profile p) noexcept;
std::span<const ProfileSpec> all_profiles() noexcept;
std::optional<Profile> profile_from_name(std::string_view name) noexcept;
std::string profile_names();  // comma-separated, for messages
const HeaderSpec& header_spec(HeaderType h) noexcept;
// The FuSa profile always uses the FuSa header; a metadata "header_type": "FUSA" selects it too.
HeaderType default_header_type(Profile p) noexcept;

inline constexpr std::uint16_t kLidarPacketType = 0x1;  // non-legacy packet header's packet_type
inline constexpr std::size_t kLegacyImuPacketSize = 48;
inline constexpr std::size_t kMaxPacketSize = 65535;

// Sizes and offsets of one lidar packet, from the profile and the metadata's data_format.
struct PacketLayout {
  Profile profile = Profile::kLegacy;
  HeaderType header = HeaderType::kLegacy;
  std::size_t pixels_per_column = 0;
  std::size_t columns_per_packet = 0;
  std::size_t packet_header_size = 0;  // 0 LEGACY, 32 otherwise
  std::size_t col_header_size = 0;     // 16 LEGACY, 12 otherwise
  std::size_t pixel_size = 0;
  std::size_t col_footer_size = 0;     // 4 LEGACY (status), 0 otherwise
  std::size_t packet_footer_size = 0;  // 0 LEGACY, 32 otherwise
  std::size_t col_size = 0;
  std::size_t packet_size = 0;
  [[nodiscard]] std::size_t column_offset(std::size_t col) const noexcept { return packet_header_size + col * col_size; }
  [[nodiscard]] std::size_t pixel_offset(std::size_t col, std::size_t px) const noexcept {
    return column_offset(col) + col_header_size + px * pixel_size;
  }
};

// Throws std::invalid_argument when the sizes are zero or the packet would exceed 65535 bytes.
PacketLayout make_layout(Profile p, HeaderType h, std::size_t pixels_per_column, std::size_t columns_per_packet);

// A FieldSpec compiled for the hot loop: load `nbytes` little-endian bytes at `byte_offset`,
// shift right, mask, shift up.
struct FieldReader {
  std::uint16_t byte_offset = 0;
  std::uint8_t nbytes = 0;  // 0: field absent (reads 0)
  std::uint8_t shift = 0;
  std::uint8_t upshift = 0;
  std::uint64_t mask = 0;
  static FieldReader from(const FieldSpec& f) noexcept;
  // `p` must have byte_offset + nbytes readable bytes (the caller checked the packet size).
  [[nodiscard]] std::uint64_t read(const std::uint8_t* p) const noexcept {
    std::uint64_t w = 0;
    for (std::uint8_t i = 0; i < nbytes; ++i) w |= static_cast<std::uint64_t>(p[byte_offset + i]) << (8U * i);
    return ((w >> shift) & mask) << upshift;
  }
  [[nodiscard]] std::size_t end() const noexcept { return static_cast<std::size_t>(byte_offset) + nbytes; }
};

}  // namespace sensor_rig::lidar::ouster
