// The fused cloud's pure parts, no PCL and no DDS: the extrinsics' rotation order and signs against
// hand-computed points and their config validation (the sweep matching: test_sweep_matcher.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/drivers/fusion/fusion_config.hpp"
#include "sensor_rig/drivers/lidar/extrinsics.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr double kEps = 1e-12;

void expect_point(const std::array<double, 3>& got, double x, double y, double z) {
  EXPECT_NEAR(got[0], x, kEps);
  EXPECT_NEAR(got[1], y, kEps);
  EXPECT_NEAR(got[2], z, kEps);
}

TEST(Extrinsics, EachAngleTurnsAsRep103Says) {
  // yaw +90 (about z, counter-clockwise seen from above): forward becomes left.
  expect_point(to_transform({.yaw_deg = 90}).apply(1, 0, 0), 0, 1, 0);
  // pitch +90 (about y): forward becomes down.
  expect_point(to_transform({.pitch_deg = 90}).apply(1, 0, 0), 0, 0, -1);
  // roll +90 (about x): left becomes up.
  expect_point(to_transform({.roll_deg = 90}).apply(0, 1, 0), 0, 0, 1);
  // Translation after rotation: the LIDAR's origin is (x, y, z) in base_link.
  expect_point(to_transform({.x = 1.5, .y = -0.5, .z = 1.9, .yaw_deg = 45}).apply(0, 0, 0), 1.5, -0.5, 1.9);
}

TEST(Extrinsics, RollThenPitchThenYawAboutFixedAxes) {
  // R = Rz(yaw) Ry(pitch) Rx(roll): up, rolled +90 -> (0,-1,0), then yawed +90 -> (1,0,0).
  // (The other order, Rx Rz, would give (0,-1,0): the test tells them apart.)
  expect_point(to_transform({.roll_deg = 90, .yaw_deg = 90}).apply(0, 0, 1), 1, 0, 0);
  // A front-left corner LIDAR: 2 m ahead of it at yaw 30 deg, mounted at (3.6, 0.8, 1.5).
  const double c = std::cos(30.0 * std::numbers::pi / 180.0);
  expect_point(to_transform({.x = 3.6, .y = 0.8, .z = 1.5, .yaw_deg = 30}).apply(2, 0, 0), 3.6 + 2 * c, 0.8 + 1.0, 1.5);
  // Pitched down 10 deg: a point 10 m ahead on the LIDAR's axis is 10 sin(10 deg) lower.
  const auto p = to_transform({.z = 2.0, .pitch_deg = 10}).apply(10, 0, 0);
  EXPECT_NEAR(p[0], 10 * std::cos(10.0 * std::numbers::pi / 180.0), 1e-9);
  EXPECT_NEAR(p[2], 2.0 - 10 * std::sin(10.0 * std::numbers::pi / 180.0), 1e-9);
}

TEST(Extrinsics, RotationIsOrthonormal) {
  const auto t = to_transform({.roll_deg = 12.5, .pitch_deg = -33, .yaw_deg = 171});
  const auto& r = t.rotation;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += r[static_cast<std::size_t>(3 * i + k)] * r[static_cast<std::size_t>(3 * j + k)];
      EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-12);
    }
}

std::shared_ptr<config::Problems> parse_extrinsics_text(const std::string& text, Extrinsics& out) {
  auto problems = std::make_shared<config::Problems>();
  const auto root = config::Node::load_string(text, "x.yaml", problems);
  if (auto e = root.child("extrinsics")) out = parse_extrinsics(*e);
  return problems;
}

TEST(Extrinsics, ConfigIsValidated) {
  Extrinsics e;
  auto p = parse_extrinsics_text("extrinsics: {x: 1.2, z: 1.9, yaw_deg: -90}\n", e);
  EXPECT_TRUE(p->empty());
  EXPECT_DOUBLE_EQ(e.x, 1.2);
  EXPECT_DOUBLE_EQ(e.y, 0.0);
  EXPECT_DOUBLE_EQ(e.yaw_deg, -90.0);
  p = parse_extrinsics_text("extrinsics:\n  pitch_deg: 120\n  z: 1200\n  yaw: 3\n", e);
  ASSERT_EQ(p->items().size(), 3u);
  for (const auto& item : p->items()) EXPECT_EQ(item.file, "x.yaml");
  EXPECT_EQ(p->items()[0].line, 4);  // unknown key yaw (allow_keys first)
  EXPECT_EQ(p->items()[1].line, 3);  // z out of range
  EXPECT_EQ(p->items()[2].line, 2);  // pitch beyond 90
}

TEST(FusionConfig, CropBoxAndTimingValidated) {
  auto problems = std::make_shared<config::Problems>();
  auto root = config::Node::load_string(
      "fusion:\n  crop_box: {x_min: 2, x_max: 1, y_min: -1, y_max: 1, z_min: 0, z_max: 2}\n  timeout_ms: 50\n"
      "  max_spread_ms: 100\n  voxel_leaf: 0.001\n",
      "f.yaml", problems);
  const auto f = parse_fusion_config(*root.child("fusion"));
  ASSERT_EQ(problems->items().size(), 3u) << problems->items()[0].str();
  EXPECT_EQ(problems->items()[0].line, 2);  // x_max <= x_min
  EXPECT_EQ(problems->items()[1].line, 5);  // voxel leaf
  EXPECT_EQ(problems->items()[2].line, 3);  // timeout <= spread
  EXPECT_TRUE(f.crop_box.enabled);
}

}  // namespace
}  // namespace sensor_rig::drivers
