#pragma once
// PCD v0.7 binary files of PointXYZIRT (vendor-neutral). Fields, in this order:
//   x y z intensity (float32), t (uint32, ns after the scan stamp), ring (uint16), return_type (uint8)
// packed, 23 bytes per point, little-endian, organised as WIDTH = points, HEIGHT = 1.
// The reader accepts exactly what the writer produces (for tests and tools), with clear errors.
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar {

struct PcdError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The PCD header + binary body as bytes.
std::string encode_pcd(std::span<const PointXYZIRT> points);
// Writes `path` (via a temporary file renamed into place). Throws PcdError on I/O failure.
void write_pcd(const std::string& path, std::span<const PointXYZIRT> points);
// Parses a file written by write_pcd/encode_pcd. Throws PcdError naming what is wrong.
std::vector<PointXYZIRT> decode_pcd(std::string_view bytes, const std::string& source);
std::vector<PointXYZIRT> read_pcd(const std::string& path);

}  // namespace sensor_rig::lidar
