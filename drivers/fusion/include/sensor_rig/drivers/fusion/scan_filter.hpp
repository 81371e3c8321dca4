#pragma once
// One LIDAR's scan on its way into the fused cloud: into base_link (its extrinsics), the ego
// vehicle's crop box removed, optionally voxel-filtered (per LIDAR: a voxel keeps one source id).
// PCL does the work (pcl::transformPointCloud, pcl::CropBox, pcl::VoxelGrid) in scan_filter.cpp,
// the only file that includes PCL: its headers are slow to compile and stay out of everything else.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "sensor_rig/drivers/fusion/fusion_config.hpp"
#include "sensor_rig/drivers/fusion/fused_point.hpp"
#include "sensor_rig/drivers/lidar/extrinsics.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::drivers {

struct ScanFilterCounters {
  std::uint64_t scans = 0;
  std::uint64_t points_in = 0;
  std::uint64_t cropped = 0;         // inside the ego vehicle's box
  std::uint64_t voxel_removed = 0;   // merged into another point of their voxel
  std::uint64_t voxel_overflow = 0;  // scans too wide for the leaf (PCL's 32-bit grid): not voxel-filtered
};

class ScanFilter {
 public:
  ScanFilter(const RigidTransform& to_base, const CropBoxConfig& crop, double voxel_leaf_m, std::uint16_t source);
  ~ScanFilter();
  ScanFilter(ScanFilter&&) noexcept;
  ScanFilter& operator=(ScanFilter&&) noexcept;

  // Appends to `out` the points in base_link with this filter's source id and t as in the scan (ns
  // after the scan's stamp; a voxel's t is the mean of its points', its intensity too). Appending:
  // a sweep's scans land in the published buffer as they come, never copied again.
  void apply(std::span<const lidar::PointXYZIRT> in, std::vector<FusedPoint>& out);
  [[nodiscard]] const ScanFilterCounters& counters() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::drivers
