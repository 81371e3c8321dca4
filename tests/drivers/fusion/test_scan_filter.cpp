// ScanFilter (the PCL part of the fused cloud): PCL's transform agrees with the extrinsics' own
// math, the ego vehicle's crop box removes what is inside it, the voxel filter merges a voxel's
// points (mean position, intensity and t; one source), and a cloud too wide for PCL's 32-bit
// voxel index passes unfiltered and counted instead of PCL's silent copy.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "sensor_rig/drivers/fusion/scan_filter.hpp"

namespace sensor_rig::drivers {
namespace {

lidar::PointXYZIRT pt(float x, float y, float z, float intensity = 1.0F, std::uint32_t t = 0) {
  return {x, y, z, intensity, t, 0, 1, 0};
}

TEST(ScanFilter, PclTransformAgreesWithTheExtrinsics) {
  const Extrinsics e{.x = 1.2, .y = -0.7, .z = 1.9, .roll_deg = 3, .pitch_deg = -8, .yaw_deg = -120};
  ScanFilter f(to_transform(e), {}, 0.0, 2);
  const std::vector<lidar::PointXYZIRT> in{pt(10, 0, 0, 5, 11), pt(-3, 4, 0.5F, 6, 22), pt(0, 0, -1.9F, 7, 33)};
  std::vector<FusedPoint> out;
  f.apply(in, out);
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    const auto want = to_transform(e).apply(in[i].x, in[i].y, in[i].z);
    EXPECT_NEAR(static_cast<double>(out[i].x), want[0], 1e-5);
    EXPECT_NEAR(static_cast<double>(out[i].y), want[1], 1e-5);
    EXPECT_NEAR(static_cast<double>(out[i].z), want[2], 1e-5);
    EXPECT_EQ(out[i].intensity, in[i].intensity);
    EXPECT_EQ(out[i].t, in[i].t);
    EXPECT_EQ(out[i].source, 2);
  }
}

TEST(ScanFilter, CropBoxRemovesTheEgoVehicle) {
  CropBoxConfig box{true, {-1.0, -1.0, -0.5}, {4.0, 1.0, 2.0}};
  ScanFilter f(to_transform({.z = 1.9}), box, 0.0, 0);  // a roof LIDAR 1.9 m above base_link
  const std::vector<lidar::PointXYZIRT> in{
      pt(0, 0, -1.5F, 1, 1),      // the roof: z 0.4 in base_link, inside
      pt(3.9F, 0.9F, -0.1F, 1, 2),  // the bonnet's corner, inside
      pt(4.1F, 0, -1.5F, 1, 3),   // just ahead of the car
      pt(20, 5, -1.8F, 1, 4),     // the road
      pt(0, 1.2F, -1.5F, 1, 5),   // beside the car
  };
  std::vector<FusedPoint> out;
  f.apply(in, out);
  std::vector<std::uint32_t> kept;
  for (const auto& p : out) kept.push_back(p.t);
  EXPECT_EQ(kept, (std::vector<std::uint32_t>{3, 4, 5}));
  EXPECT_EQ(f.counters().cropped, 2u);
  EXPECT_EQ(f.counters().points_in, 5u);
}

TEST(ScanFilter, VoxelMergesItsPointsWithMeanTimeAndIntensity) {
  ScanFilter f({}, {}, 1.0, 1);
  const std::vector<lidar::PointXYZIRT> in{
      pt(0.1F, 0.1F, 0.1F, 10, 1'000'000), pt(0.9F, 0.1F, 0.1F, 20, 2'000'000),
      pt(0.1F, 0.9F, 0.5F, 30, 3'000'000), pt(0.5F, 0.5F, 0.9F, 40, 4'000'000),
      pt(5.5F, 0.5F, 0.5F, 50, 7),  // alone in its voxel
  };
  std::vector<FusedPoint> out;
  f.apply(in, out);
  ASSERT_EQ(out.size(), 2u);
  std::sort(out.begin(), out.end(), [](const FusedPoint& a, const FusedPoint& b) { return a.x < b.x; });
  EXPECT_NEAR(static_cast<double>(out[0].x), 0.4, 1e-5);
  EXPECT_NEAR(static_cast<double>(out[0].y), 0.4, 1e-5);
  EXPECT_NEAR(static_cast<double>(out[0].z), 0.4, 1e-5);
  EXPECT_NEAR(static_cast<double>(out[0].intensity), 25.0, 1e-4);
  EXPECT_NEAR(static_cast<double>(out[0].t), 2'500'000.0, 1.0);
  EXPECT_EQ(out[1].t, 7u);
  EXPECT_EQ(out[1].source, 1);
  EXPECT_EQ(f.counters().voxel_removed, 3u);
  EXPECT_EQ(f.counters().voxel_overflow, 0u);
}

TEST(ScanFilter, CloudTooWideForTheLeafPassesUnfilteredAndCounted) {
  ScanFilter f({}, {}, 0.01, 0);
  const std::vector<lidar::PointXYZIRT> in{pt(-300, -300, -30), pt(-300, -300, -30), pt(300, 300, 30)};
  std::vector<FusedPoint> out;
  f.apply(in, out);
  EXPECT_EQ(out.size(), 3u);
  EXPECT_EQ(f.counters().voxel_overflow, 1u);
}

}  // namespace
}  // namespace sensor_rig::drivers
