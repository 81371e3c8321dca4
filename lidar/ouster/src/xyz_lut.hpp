#pragma once
// Per-pixel projection table (ouster-sdk's make_xyz_lut model): for column index (measurement id)
// c and row (beam) r, with encoder angle e = 2pi - 2pi c / W, beam azimuth a = -azimuth_deg[r],
// altitude p = altitude_deg[r], beam offset d = |beam_to_lidar (0,3),(2,3)|:
//   dir    = (cos(e+a) cos p, sin(e+a) cos p, sin p)
//   offset = (bx cos e - d dir.x, bx sin e - d dir.y, bz - d dir.z)     (bx, bz: beam_to_lidar (0,3), (2,3))
//   point  = R (range_mm dir + offset) + t, then mm -> m       (R, t: lidar_to_sensor_transform)
// Stored column-major (a column's rows are contiguous) as float, direction pre-scaled to m per mm.
#include <cstddef>
#include <vector>

#include "sensor_rig/lidar/ouster/metadata.hpp"

namespace sensor_rig::lidar::ouster {

struct LutEntry {
  float dx, dy, dz;  // m per mm of range
  float ox, oy, oz;  // m
};

class XyzLut {
 public:
  explicit XyzLut(const SensorMetadata& m);
  // Rows of column `c` (c < columns()).
  [[nodiscard]] const LutEntry* column(std::size_t c) const noexcept { return entries_.data() + c * rows_; }
  [[nodiscard]] std::size_t columns() const noexcept { return cols_; }
  [[nodiscard]] std::size_t rows() const noexcept { return rows_; }

 private:
  std::size_t cols_ = 0;
  std::size_t rows_ = 0;
  std::vector<LutEntry> entries_;
};

}  // namespace sensor_rig::lidar::ouster
