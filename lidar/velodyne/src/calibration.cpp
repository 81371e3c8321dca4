// Built-in calibrations (manual values) and model validation.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "sensor_rig/lidar/velodyne/calibration.hpp"

namespace sensor_rig::lidar::velodyne {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// VLP-16 manual, table "Laser ID / vertical angle / vertical correction (mm)".
constexpr std::array<double, 16> kVlp16Vert{-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15};
constexpr std::array<double, 16> kVlp16VertOffsetMm{11.2, -0.7, 9.7, -2.2, 8.1, -3.7, 6.6, -5.1,
                                                    5.1,  -6.6, 3.7, -8.1, 2.2, -9.7, 0.7, -11.2};
// HDL-32E manual, laser firing order and vertical angles.
constexpr std::array<double, 32> kHdl32Vert{
    -30.67, -9.33, -29.33, -8.00, -28.00, -6.67, -26.67, -5.33, -25.33, -4.00, -24.00,
    -2.67,  -22.67, -1.33, -21.33, 0.00,  -20.00, 1.33,  -18.67, 2.67,  -17.33, 4.00,
    -16.00, 5.33,  -14.67, 6.67,  -13.33, 8.00,  -12.00, 9.33,  -10.67, 10.67};
// VLP-32C manual: vertical angle and azimuth offset per laser id. The rotation correction is the
// negated azimuth offset (it is subtracted from the azimuth, as in ROS and VeloView).
constexpr std::array<double, 32> kVlp32Vert{
    -25,    -1,     -1.667, -15.639, -11.31, 0,      -0.667, -8.843, -7.254, 0.333, -0.333,
    -6.148, -5.333, 1.333,  0.667,   -4,     -4.667, 1.667,  1,      -3.667, -3.333, 3.333,
    2.333,  -2.667, -3,     7,       4.667,  -2.333, -2,     15,     10.333, -1.333};
constexpr std::array<double, 32> kVlp32AzimuthOffset{
    1.4, -4.2, 1.4, -1.4, 1.4, -1.4, 4.2, -1.4, 1.4, -4.2, 1.4, -1.4, 4.2, -1.4, 4.2, -1.4,
    1.4, -4.2, 1.4, -4.2, 4.2, -1.4, 1.4, -1.4, 1.4, -1.4, 1.4, -4.2, 4.2, -1.4, 1.4, -1.4};

[[noreturn]] void fail(const Calibration& c, const std::string& what) {
  throw CalibrationError(c.source + ": " + what);
}

}  // namespace

Calibration default_calibration(Model m) {
  const ModelInfo& info = model_info(m);
  Calibration c;
  c.distance_resolution_m = info.distance_resolution_m;
  c.source = "built-in " + std::string(info.name);
  c.lasers.resize(static_cast<std::size_t>(info.lasers));
  for (int i = 0; i < info.lasers; ++i) {
    auto& l = c.lasers[static_cast<std::size_t>(i)];
    const auto u = static_cast<std::size_t>(i);
    l.laser_id = i;
    switch (m) {
      case Model::kVLP16:
        l.vert_correction = kVlp16Vert[u] * kDeg;
        l.vert_offset_correction = kVlp16VertOffsetMm[u] / 1000.0;
        break;
      case Model::kVLP32C:
        l.vert_correction = kVlp32Vert[u] * kDeg;
        l.rot_correction = -kVlp32AzimuthOffset[u] * kDeg;
        break;
      case Model::kHDL32E:
        l.vert_correction = kHdl32Vert[u] * kDeg;
        break;
    }
  }
  return c;
}

Calibration validate_for_model(Calibration c, Model m) {
  const ModelInfo& info = model_info(m);
  if (!(c.distance_resolution_m > 0.0 && c.distance_resolution_m < 0.1)) {
    fail(c, "distance_resolution " + std::to_string(c.distance_resolution_m) +
                " m is out of range (0, 0.1)");
  }
  if (c.lasers.size() < static_cast<std::size_t>(info.lasers)) {
    fail(c, "has " + std::to_string(c.lasers.size()) + " lasers, " + std::string(info.name) + " needs " +
                std::to_string(info.lasers));
  }
  std::vector<LaserCorrection> by_id(static_cast<std::size_t>(info.lasers));
  std::vector<bool> seen(by_id.size(), false);
  for (const auto& l : c.lasers) {
    if (l.laser_id < 0) fail(c, "negative laser_id " + std::to_string(l.laser_id));
    // VeloView files list 64 entries whatever the model; ids beyond the model are unused.
    if (l.laser_id >= info.lasers) continue;
    const auto id = static_cast<std::size_t>(l.laser_id);
    if (seen[id]) fail(c, "laser_id " + std::to_string(l.laser_id) + " appears twice");
    for (double v : {l.rot_correction, l.vert_correction, l.dist_correction, l.dist_correction_x,
                     l.dist_correction_y, l.vert_offset_correction, l.horiz_offset_correction}) {
      if (!std::isfinite(v)) fail(c, "laser " + std::to_string(l.laser_id) + " has a non-finite value");
    }
    if (std::abs(l.vert_correction) > std::numbers::pi / 2) {
      fail(c, "laser " + std::to_string(l.laser_id) + " vert_correction is beyond ±90°");
    }
    if (std::abs(l.rot_correction) > std::numbers::pi) {
      fail(c, "laser " + std::to_string(l.laser_id) + " rot_correction is beyond ±180°");
    }
    if (l.dist_correction_x != 0.0 || l.dist_correction_y != 0.0) {
      fail(c, "laser " + std::to_string(l.laser_id) +
                  ": dist_correction_x/y (HDL-64 two-point correction) is not supported for " +
                  std::string(info.name));
    }
    if (std::abs(l.dist_correction) > 10.0 || std::abs(l.vert_offset_correction) > 1.0 ||
        std::abs(l.horiz_offset_correction) > 1.0) {
      fail(c, "laser " + std::to_string(l.laser_id) + " has an implausible distance/offset correction");
    }
    by_id[id] = l;
    seen[id] = true;
  }
  const auto missing = std::find(seen.begin(), seen.end(), false);
  if (missing != seen.end()) {
    fail(c, "laser_id " + std::to_string(missing - seen.begin()) + " is missing (" + std::string(info.name) +
                " has " + std::to_string(info.lasers) + " lasers)");
  }
  c.lasers = std::move(by_id);
  return c;
}

Calibration parse_calibration(const std::string& text, const std::string& source) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text.compare(first, 1, "<") == 0) return parse_veloview_xml(text, source);
  return parse_ros_yaml(text, source);
}

}  // namespace sensor_rig::lidar::velodyne
