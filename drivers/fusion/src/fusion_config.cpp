#include "sensor_rig/drivers/fusion/fusion_config.hpp"

namespace sensor_rig::drivers {
namespace {

CropBoxConfig parse_crop_box(const config::Node& n) {
  CropBoxConfig b;
  if (!n.expect_map()) return b;
  n.allow_keys({"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"});
  constexpr double kLimit = 50.0;  // metres from base_link: the car, not the world
  const char* keys[3][2] = {{"x_min", "x_max"}, {"y_min", "y_max"}, {"z_min", "z_max"}};
  for (std::size_t i = 0; i < 3; ++i) {
    b.min[i] = n.get_double(keys[i][0], -kLimit, kLimit);
    b.max[i] = n.get_double(keys[i][1], -kLimit, kLimit);
    if (n.has(keys[i][0]) && n.has(keys[i][1]) && b.min[i] >= b.max[i])
      n.fail(keys[i][1], "must be greater than " + std::string(keys[i][0]));
  }
  b.enabled = true;
  return b;
}

}  // namespace

FusionConfig parse_fusion_config(const config::Node& n) {
  FusionConfig f;
  if (!n.expect_map()) return f;
  n.allow_keys({"enable", "frame_id", "crop_box", "voxel_leaf", "timeout_ms", "max_spread_ms", "realtime_priority", "qos"});
  f.enabled = n.get_bool("enable", true);
  f.frame_id = n.get_string("frame_id", "base_link");
  if (f.frame_id.empty()) n.fail("frame_id", "must not be empty");
  if (auto b = n.child("crop_box")) f.crop_box = parse_crop_box(*b);
  // 0 = off. PCL's grid index is 32 bits: a cloud too wide for its leaf passes unfiltered, counted.
  f.voxel_leaf_m = n.get_double("voxel_leaf", 0.0, 10.0, 0.0);
  if (f.voxel_leaf_m > 0.0 && f.voxel_leaf_m < 0.01) n.fail("voxel_leaf", "0 (off) or at least 0.01 m");
  f.max_spread_ms = static_cast<int>(n.get_int("max_spread_ms", 1, 1000, 100));
  f.timeout_ms = static_cast<int>(n.get_int("timeout_ms", 1, 5000, 150));
  if (f.timeout_ms <= f.max_spread_ms)
    n.fail("timeout_ms", "must be greater than max_spread_ms (" + std::to_string(f.max_spread_ms) +
                             "): a sweep's last scan arrives up to max_spread after its first");
  f.realtime_priority = static_cast<int>(n.get_int("realtime_priority", 0, 98, 0));
  if (auto q = n.child("qos")) f.qos = dds::QosSpec::from_config(*q, f.qos);
  return f;
}

}  // namespace sensor_rig::drivers
