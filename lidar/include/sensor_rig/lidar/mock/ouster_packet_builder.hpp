#pragma once
// Ouster packets and metadata JSON for tests, fuzz corpora and benchmarks. The byte layouts are
// written out by hand from the firmware manual, independent of the decoder's field tables, so a
// wrong table entry shows up as a test failure.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "sensor_rig/lidar/ouster/profile.hpp"

namespace sensor_rig::lidar::ouster::builder {

struct Echo {
  std::uint32_t range_mm = 0;
  std::uint8_t reflectivity = 0;
  std::uint16_t signal = 0;
};
struct Pixel {
  Echo first;
  Echo second;  // dual-return profiles only
  std::uint16_t near_ir = 0;
};

inline void put(std::uint8_t* p, std::uint64_t v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Bytes of one pixel, per the manual's "Lidar Data Packet Format" tables.
inline void encode_pixel(Profile prof, std::uint8_t* p, const Pixel& px) {
  const auto& a = px.first;
  const auto& b = px.second;
  switch (prof) {
    case Profile::kLegacy:  // range 20 bits | reflectivity u16 | signal u16 | near-IR u16 | 2 unused
      put(p, a.range_mm & 0xFFFFF, 4);
      put(p + 4, a.reflectivity, 2);
      put(p + 6, a.signal, 2);
      put(p + 8, px.near_ir, 2);
      break;
    case Profile::kRng19Rfl8Sig16Nir16:  // range 19 bits (3 B) | - | refl | - | signal | near-IR | - | window
      put(p, a.range_mm & 0x7FFFF, 3);
      p[4] = a.reflectivity;
      put(p + 6, a.signal, 2);
      put(p + 8, px.near_ir, 2);
      break;
    case Profile::kRng19Rfl8Sig16Nir16Dual:
    case Profile::kFiveWordPixel:  // range1 19 | refl1 | range2 19 | refl2 | signal1 | signal2 | near-IR
      put(p, a.range_mm & 0x7FFFF, 3);
      p[3] = a.reflectivity;
      put(p + 4, b.range_mm & 0x7FFFF, 3);
      p[7] = b.reflectivity;
      put(p + 8, a.signal, 2);
      put(p + 10, b.signal, 2);
      put(p + 12, px.near_ir, 2);
      break;
    case Profile::kRng15Rfl8Nir8:  // range/8 15 bits | refl | near-IR/16
      put(p, (a.range_mm >> 3) & 0x7FFF, 2);
      p[2] = a.reflectivity;
      p[3] = static_cast<std::uint8_t>(px.near_ir >> 4);
      break;
    case Profile::kRng15Rfl8Win8:  // range/8 15 bits | refl | window
      put(p, (a.range_mm >> 3) & 0x7FFF, 2);
      p[2] = a.reflectivity;
      break;
    case Profile::kFusaRng15Rfl8Nir8Dual:
    case Profile::kRng15Rfl8Nir8Dual:  // range1/8 | refl1 | near-IR/16 | range2/8 | refl2 | window
      put(p, (a.range_mm >> 3) & 0x7FFF, 2);
      p[2] = a.reflectivity;
      p[3] = static_cast<std::uint8_t>(px.near_ir >> 4);
      put(p + 4, (b.range_mm >> 3) & 0x7FFF, 2);
      p[6] = b.reflectivity;
      break;
  }
}

inline std::size_t pixel_bytes(Profile p) {
  switch (p) {
    case Profile::kLegacy:
    case Profile::kRng19Rfl8Sig16Nir16:
      return 12;
    case Profile::kRng19Rfl8Sig16Nir16Dual:
      return 16;
    case Profile::kRng15Rfl8Nir8:
    case Profile::kRng15Rfl8Win8:
      return 4;
    case Profile::kFiveWordPixel:
      return 20;
    case Profile::kFusaRng15Rfl8Nir8Dual:
    case Profile::kRng15Rfl8Nir8Dual:
      return 8;
  }
  return 0;
}

struct Column {
  std::uint64_t timestamp_ns = 0;
  std::uint16_t measurement_id = 0;
  bool valid = true;
  std::vector<Pixel> pixels;
};

// One lidar packet: LEGACY = columns only (16 B header, pixels, 4 B status); others = 32 B packet
// header (standard or FuSa) + columns (12 B header) + 32 B footer.
inline std::vector<std::uint8_t> encode_packet(Profile prof, std::size_t pixels_per_column, std::uint32_t frame_id,
                                               const std::vector<Column>& cols, std::uint32_t init_id = 0) {
  const bool legacy = prof == Profile::kLegacy;
  const bool fusa = prof == Profile::kFusaRng15Rfl8Nir8Dual;
  const std::size_t pb = pixel_bytes(prof);
  const std::size_t col_size = (legacy ? 16 + 4 : 12) + pixels_per_column * pb;
  const std::size_t head = legacy ? 0 : 32;
  std::vector<std::uint8_t> out(head + cols.size() * col_size + (legacy ? 0 : 32), 0);
  if (fusa) {
    out[0] = 1;
    put(&out[1], init_id, 3);
    put(&out[4], frame_id, 4);
  } else if (!legacy) {
    put(&out[0], 1, 2);
    put(&out[2], frame_id, 2);
    put(&out[4], init_id, 3);
  }
  for (std::size_t c = 0; c < cols.size(); ++c) {
    std::uint8_t* col = out.data() + head + c * col_size;
    put(col, cols[c].timestamp_ns, 8);
    put(col + 8, cols[c].measurement_id, 2);
    if (legacy) {
      put(col + 10, frame_id, 2);
      put(col + 12, static_cast<std::uint64_t>(cols[c].measurement_id) * 88, 4);  // encoder count
      put(col + col_size - 4, cols[c].valid ? 0xFFFFFFFFU : 0U, 4);
    } else {
      put(col + 10, cols[c].valid ? 1U : 0U, 2);
    }
    const std::size_t hdr = legacy ? 16 : 12;
    for (std::size_t r = 0; r < pixels_per_column && r < cols[c].pixels.size(); ++r)
      encode_pixel(prof, col + hdr + r * pb, cols[c].pixels[r]);
  }
  return out;
}

// Nested (FW 2.4+) metadata JSON for a synthetic sensor. Altitudes from +alt_top down in equal
// steps, azimuths alternate +/-az; beam origin offset, lidar_to_sensor as Ouster ships it.
inline std::string nested_metadata(const std::string& profile, int pixels, int columns_per_frame = 1024,
                                   int fps = 10, double beam_offset_mm = 15.806, double alt_top = 10.0,
                                   double az = 2.0) {
  std::ostringstream alt, azs, shift;
  for (int i = 0; i < pixels; ++i) {
    alt << (i ? ", " : "") << alt_top - 20.0 * i / pixels;
    azs << (i ? ", " : "") << (i % 2 ? -az : az);
    shift << (i ? ", " : "") << (i % 4) * 8;
  }
  std::ostringstream j;
  j << R"({"sensor_info": {"prod_line": "OS-TEST", "prod_sn": "992200000001", "build_rev": "v2.5.0",
"initialization_id": 7654321},
"beam_intrinsics": {"beam_altitude_angles": [)" << alt.str() << R"(], "beam_azimuth_angles": [)" << azs.str()
    << R"(], "lidar_origin_to_beam_origin_mm": )" << beam_offset_mm << R"(,
"beam_to_lidar_transform": [1, 0, 0, )" << beam_offset_mm << R"(, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},
"lidar_intrinsics": {"lidar_to_sensor_transform": [-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1]},
"lidar_data_format": {"column_window": [0, )" << columns_per_frame - 1 << R"(], "columns_per_frame": )"
    << columns_per_frame << R"(, "columns_per_packet": 16, "pixel_shift_by_row": [)" << shift.str()
    << R"(], "pixels_per_column": )" << pixels << R"(, "udp_profile_lidar": ")" << profile << R"("},
"config_params": {"lidar_mode": ")" << columns_per_frame << "x" << fps << R"(", "udp_port_lidar": 7502,
"udp_port_imu": 7503, "udp_profile_lidar": ")" << profile << R"("}})";
  return j.str();
}

}  // namespace sensor_rig::lidar::ouster::builder
