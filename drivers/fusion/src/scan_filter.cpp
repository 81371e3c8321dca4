// The only translation unit of the rig that includes PCL (scan_filter.hpp says why).
#include "sensor_rig/drivers/fusion/scan_filter.hpp"

#include <pcl/common/common.h>
#include <pcl/common/transforms.h>
#include <pcl/filters/crop_box.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdint>
#include <limits>

namespace sensor_rig::drivers {
namespace {

Eigen::Affine3f affine(const RigidTransform& t) {
  Eigen::Affine3f a = Eigen::Affine3f::Identity();
  for (std::size_t r = 0; r < 3; ++r) {
    const auto row = static_cast<Eigen::Index>(r);
    for (std::size_t c = 0; c < 3; ++c) a.matrix()(row, static_cast<Eigen::Index>(c)) = static_cast<float>(t.rotation[3 * r + c]);
    a.matrix()(row, 3) = static_cast<float>(t.translation[r]);
  }
  return a;
}

// PCL's own check (voxel_grid.hpp): beyond 2^31 cells it would copy the input with a warning.
bool grid_fits(const pcl::PointCloud<pcl::PointXYZINormal>& cloud, double leaf) {
  Eigen::Vector4f lo, hi;
  pcl::getMinMax3D(cloud, lo, hi);
  const auto inverse = static_cast<float>(1.0 / leaf);
  std::int64_t cells = 1;
  for (int i = 0; i < 3; ++i) cells *= static_cast<std::int64_t>((hi[i] - lo[i]) * inverse) + 1;
  return cells <= static_cast<std::int64_t>(std::numeric_limits<std::int32_t>::max());
}

}  // namespace

struct ScanFilter::Impl {
  Eigen::Affine3f to_base;
  CropBoxConfig crop_config;
  double leaf;
  std::uint16_t source;
  ScanFilterCounters counters;
  pcl::PointCloud<pcl::PointXYZI>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZI>};
  pcl::Indices kept;
  pcl::CropBox<pcl::PointXYZI> crop;
  // Voxels: t rides in `curvature`, which the grid averages like intensity (setDownsampleAllData).
  pcl::PointCloud<pcl::PointXYZINormal>::Ptr voxel_in{new pcl::PointCloud<pcl::PointXYZINormal>};
  pcl::PointCloud<pcl::PointXYZINormal> voxel_out;
  pcl::VoxelGrid<pcl::PointXYZINormal> voxel;

  Impl(const RigidTransform& t, const CropBoxConfig& c, double leaf_m, std::uint16_t src)
      : to_base(affine(t)), crop_config(c), leaf(leaf_m), source(src) {
    crop.setMin(Eigen::Vector4f(static_cast<float>(c.min[0]), static_cast<float>(c.min[1]), static_cast<float>(c.min[2]), 1.0F));
    crop.setMax(Eigen::Vector4f(static_cast<float>(c.max[0]), static_cast<float>(c.max[1]), static_cast<float>(c.max[2]), 1.0F));
    crop.setNegative(true);  // keep what is outside the ego vehicle
    const auto l = static_cast<float>(leaf);
    voxel.setLeafSize(l, l, l);
    voxel.setDownsampleAllData(true);
  }

  void to_cloud(std::span<const lidar::PointXYZIRT> in) {
    cloud->resize(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
      auto& p = (*cloud)[i];
      p.x = in[i].x;
      p.y = in[i].y;
      p.z = in[i].z;
      p.intensity = in[i].intensity;
    }
    pcl::transformPointCloud(*cloud, *cloud, to_base);
  }

  void select() {
    if (crop_config.enabled) {
      crop.setInputCloud(cloud);
      crop.filter(kept);
    } else {
      kept.resize(cloud->size());
      for (std::size_t i = 0; i < kept.size(); ++i) kept[i] = static_cast<pcl::index_t>(i);
    }
  }

  // Appended with push_back: a resize would zero the new points first (megabytes per sweep).
  void emit_kept(std::span<const lidar::PointXYZIRT> in, std::vector<FusedPoint>& out) const {
    out.reserve(out.size() + kept.size());
    for (const auto k : kept) {
      const auto i = static_cast<std::size_t>(k);
      const auto& p = (*cloud)[i];
      out.push_back({p.x, p.y, p.z, p.intensity, in[i].t, source, 0});
    }
  }

  void emit_voxels(std::span<const lidar::PointXYZIRT> in, std::vector<FusedPoint>& out) {
    voxel_in->resize(kept.size());
    for (std::size_t k = 0; k < kept.size(); ++k) {
      const auto i = static_cast<std::size_t>(kept[k]);
      const auto& p = (*cloud)[i];
      auto& v = (*voxel_in)[k];
      v.x = p.x;
      v.y = p.y;
      v.z = p.z;
      v.intensity = p.intensity;
      v.normal_x = v.normal_y = v.normal_z = 0.0F;
      v.curvature = static_cast<float>(in[i].t);
    }
    if (!grid_fits(*voxel_in, leaf)) {
      ++counters.voxel_overflow;
      emit_kept(in, out);
      return;
    }
    voxel.setInputCloud(voxel_in);
    voxel.filter(voxel_out);
    counters.voxel_removed += kept.size() - voxel_out.size();
    out.reserve(out.size() + voxel_out.size());
    for (const auto& v : voxel_out) {
      const auto t = std::lround(static_cast<double>(v.curvature));
      out.push_back({v.x, v.y, v.z, v.intensity, static_cast<std::uint32_t>(t < 0 ? 0 : t), source, 0});
    }
  }
};

ScanFilter::ScanFilter(const RigidTransform& to_base, const CropBoxConfig& crop, double voxel_leaf_m, std::uint16_t source)
    : impl_(std::make_unique<Impl>(to_base, crop, voxel_leaf_m, source)) {}
ScanFilter::~ScanFilter() = default;
ScanFilter::ScanFilter(ScanFilter&&) noexcept = default;
ScanFilter& ScanFilter::operator=(ScanFilter&&) noexcept = default;

void ScanFilter::apply(std::span<const lidar::PointXYZIRT> in, std::vector<FusedPoint>& out) {
  auto& m = *impl_;
  ++m.counters.scans;
  m.counters.points_in += in.size();
  m.to_cloud(in);
  m.select();
  m.counters.cropped += in.size() - m.kept.size();
  if (m.leaf > 0.0) {
    m.emit_voxels(in, out);
  } else {
    m.emit_kept(in, out);
  }
}

const ScanFilterCounters& ScanFilter::counters() const noexcept { return impl_->counters; }

}  // namespace sensor_rig::drivers
