#pragma once
// Ouster sensor metadata (the JSON `get_metadata` returns / ouster-sdk saves beside a capture):
// what the decoder needs to lay out packets and project points. Both formats are read:
//   flat   (FW 1.x-2.3): beam_altitude_angles, lidar_origin_to_beam_origin_mm,
//                        lidar_to_sensor_transform, lidar_mode at the top, data_format{...}
//   nested (FW 2.4+ / SDK 0.9+): beam_intrinsics{...}, lidar_intrinsics{...},
//                        lidar_data_format{...}, config_params{...}, sensor_info{...}
// Errors throw MetadataError (a DecoderConfigError) naming the source and the key.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/lidar/ouster/profile.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::ouster {

struct MetadataError : DecoderConfigError {
  using DecoderConfigError::DecoderConfigError;
};

// Order of the returns of dual-return profiles (config_params.return_order, FW 2.5+).
enum class ReturnOrder : std::uint8_t { kStrongestFirst, kFarthestFirst, kNearestFirst };

using Mat4 = std::array<double, 16>;  // row-major homogeneous transform, translation in mm
inline constexpr Mat4 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

struct SensorMetadata {
  std::string source;                  // file name, for messages
  bool nested_format = false;
  std::string prod_line;               // e.g. OS-1-32-G
  std::string prod_sn;
  std::string fw_rev;                  // build_rev, e.g. v2.1.1
  std::string lidar_mode;              // e.g. 1024x10
  double frames_per_second = 0.0;      // from lidar_mode (or lidar_data_format.fps)
  std::uint32_t init_id = 0;           // 0: not in the metadata
  std::uint16_t udp_port_lidar = 7502;
  std::uint16_t udp_port_imu = 7503;

  Profile profile = Profile::kLegacy;  // udp_profile_lidar (absent: LEGACY)
  HeaderType header_type = HeaderType::kLegacy;
  ReturnOrder return_order = ReturnOrder::kStrongestFirst;
  int pixels_per_column = 0;
  int columns_per_packet = 0;
  int columns_per_frame = 0;
  int column_window_first = 0;         // column_window[0]
  int column_window_last = 0;          // column_window[1] (may be < first: the window wraps)
  std::vector<int> pixel_shift_by_row; // destaggering only (not needed for points)

  std::vector<double> beam_altitude_deg;  // per row (pixel), degrees
  std::vector<double> beam_azimuth_deg;   // per row, degrees
  Mat4 beam_to_lidar = kIdentity;      // (0,3) = lidar_origin_to_beam_origin_mm when only that is given
  Mat4 lidar_to_sensor = kIdentity;

  [[nodiscard]] PacketLayout layout() const { return make_layout(profile, header_type,
      static_cast<std::size_t>(pixels_per_column), static_cast<std::size_t>(columns_per_packet)); }
  // ns between two columns: 1e9 / (frames_per_second * columns_per_frame).
  [[nodiscard]] double column_period_ns() const noexcept {
    return 1e9 / (frames_per_second * static_cast<double>(columns_per_frame));
  }
};

// Parses and validates the metadata JSON. `source` names the file in messages.
SensorMetadata parse_metadata(std::string_view json_text, const std::string& source);

}  // namespace sensor_rig::lidar::ouster
