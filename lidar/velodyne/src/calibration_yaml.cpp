// ROS velodyne_pointcloud calibration YAML: metres and radians.
#include <memory>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"

namespace sensor_rig::lidar::velodyne {

Calibration parse_ros_yaml(const std::string& text, const std::string& source) {
  auto problems = std::make_shared<config::Problems>();
  const config::Node root = config::Node::load_string(text, source, problems);
  Calibration c;
  c.source = source;
  if (root.valid() && root.expect_map()) {
    root.allow_keys({"lasers", "num_lasers", "distance_resolution"});
    c.distance_resolution_m = root.get_double("distance_resolution", 1e-6, 0.1, 0.0);  // 0: the model's
    const auto lasers = root.items("lasers", true);
    const auto num = root.get_int("num_lasers", 1, 128, static_cast<std::int64_t>(lasers.size()));
    if (problems->empty() && num != static_cast<std::int64_t>(lasers.size())) {
      root.fail("num_lasers", "says " + std::to_string(num) + " but lasers lists " + std::to_string(lasers.size()));
    }
    c.num_lasers = static_cast<int>(num);
    constexpr double kBig = 1e3;
    for (const auto& l : lasers) {
      if (!l.expect_map()) continue;
      l.allow_keys({"laser_id", "rot_correction", "vert_correction", "dist_correction", "dist_correction_x",
                    "dist_correction_y", "vert_offset_correction", "horiz_offset_correction", "focal_distance",
                    "focal_slope", "min_intensity", "max_intensity"});
      LaserCorrection lc;
      lc.laser_id = static_cast<int>(l.get_int("laser_id", 0, 127));
      lc.rot_correction = l.get_double("rot_correction", -kBig, kBig, 0.0);
      lc.vert_correction = l.get_double("vert_correction", -kBig, kBig);
      lc.dist_correction = l.get_double("dist_correction", -kBig, kBig, 0.0);
      lc.dist_correction_x = l.get_double("dist_correction_x", -kBig, kBig, 0.0);
      lc.dist_correction_y = l.get_double("dist_correction_y", -kBig, kBig, 0.0);
      lc.vert_offset_correction = l.get_double("vert_offset_correction", -kBig, kBig, 0.0);
      lc.horiz_offset_correction = l.get_double("horiz_offset_correction", -kBig, kBig, 0.0);
      lc.focal_distance = l.get_double("focal_distance", -kBig, kBig, 0.0);
      lc.focal_slope = l.get_double("focal_slope", -kBig, kBig, 0.0);
      c.lasers.push_back(lc);
    }
  } else if (problems->empty()) {
    problems->add({source, 1, 1, "", "empty calibration file"});
  }
  if (!problems->empty()) throw CalibrationError("calibration " + source + ":\n" + problems->str());
  return c;
}

}  // namespace sensor_rig::lidar::velodyne
