// Built-in calibrations (manual values) and model validation.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>

#include "sensor_rig/common/angles.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"

namespace sensor_rig::lidar::velodyne {
namespace {

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

std::string metres(double v) {
  std::ostringstream s;
  s << v;
  return s.str() + " m";
}

bool same_corrections(const LaserCorrection& a, const LaserCorrection& b) {
  return a.rot_correction == b.rot_correction && a.vert_correction == b.vert_correction &&
         a.dist_correction == b.dist_correction && a.dist_correction_x == b.dist_correction_x &&
         a.dist_correction_y == b.dist_correction_y && a.vert_offset_correction == b.vert_offset_correction &&
         a.horiz_offset_correction == b.horiz_offset_correction;
}

bool all_zero(const LaserCorrection& l) { return same_corrections(l, LaserCorrection{.laser_id = l.laser_id}); }

const LaserCorrection* find_laser(const Calibration& c, int id) {
  for (const auto& l : c.lasers)
    if (l.laser_id == id) return &l;
  return nullptr;
}

// A calibration made for another model must not decode silently: a VLP-32C file (4 mm counts) on
// an HDL-32E doubles every range, a 32-laser file on a VLP-16 takes the wrong elevations.
// Fills in the model's resolution when the file states none.
void check_model_fit(Calibration& c, const ModelInfo& info) {
  const std::string model(info.name);
  const std::string model_res = metres(info.distance_resolution_m);
  if (c.num_lasers != 0 && c.num_lasers != info.lasers) {
    fail(c, "num_lasers " + std::to_string(c.num_lasers) + " does not match " + model + ", which has " +
                std::to_string(info.lasers) + " lasers (a calibration for another model?)");
  }
  if (c.distance_resolution_m == 0.0) c.distance_resolution_m = info.distance_resolution_m;
  // The manuals' count units: VLP-16 and HDL-32E 2 mm, VLP-32C 4 mm (ROS/VeloView files agree).
  if (!(std::abs(c.distance_resolution_m - info.distance_resolution_m) < 1e-9)) {
    fail(c, "distance_resolution " + metres(c.distance_resolution_m) + " does not match " + model + " (" +
                model_res + " per count; a calibration for another model?)");
  }
  // VeloView XML lists 64 entries whatever the model: the ones beyond the model's lasers must be
  // unused — all zero, or (VLP-16 files) a repeat of laser id % lasers.
  for (const auto& l : c.lasers) {
    if (l.laser_id < info.lasers || all_zero(l)) continue;
    const LaserCorrection* same = find_laser(c, l.laser_id % info.lasers);
    if (same != nullptr && same_corrections(*same, l)) continue;
    fail(c, "laser_id " + std::to_string(l.laser_id) + " has corrections, but " + model + " has only " +
                std::to_string(info.lasers) + " lasers (a calibration for another model?)");
  }
  // The reverse: a VLP-16 VeloView file (lasers 16..31 repeat 0..15) on a 32-laser model.
  if (info.lasers > 16) {
    bool repeats = true;
    bool any_set = false;  // an all-zero table repeats itself too, but is no VLP-16 file
    for (int id = 16; id < 32 && repeats; ++id) {
      const LaserCorrection* hi = find_laser(c, id);
      const LaserCorrection* lo = find_laser(c, id - 16);
      repeats = hi != nullptr && lo != nullptr && same_corrections(*hi, *lo);
      any_set = any_set || (lo != nullptr && !all_zero(*lo));
    }
    if (repeats && any_set) fail(c, "lasers 16-31 repeat lasers 0-15: a 16-laser (VLP-16) calibration, not for " + model);
  }
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
        l.vert_correction = kVlp16Vert[u] * kRadPerDeg;
        l.vert_offset_correction = kVlp16VertOffsetMm[u] / 1000.0;
        break;
      case Model::kVLP32C:
        l.vert_correction = kVlp32Vert[u] * kRadPerDeg;
        l.rot_correction = -kVlp32AzimuthOffset[u] * kRadPerDeg;
        break;
      case Model::kHDL32E:
        l.vert_correction = kHdl32Vert[u] * kRadPerDeg;
        break;
    }
  }
  return c;
}

Calibration validate_for_model(Calibration c, Model m) {
  const ModelInfo& info = model_info(m);
  const std::string model(info.name);
  check_model_fit(c, info);
  if (c.lasers.size() < static_cast<std::size_t>(info.lasers)) {
    fail(c, "has " + std::to_string(c.lasers.size()) + " lasers, " + model + " needs " + std::to_string(info.lasers));
  }
  std::vector<LaserCorrection> by_id(static_cast<std::size_t>(info.lasers));
  std::vector<bool> seen(by_id.size(), false);
  for (const auto& l : c.lasers) {
    if (l.laser_id < 0) fail(c, "negative laser_id " + std::to_string(l.laser_id));
    if (l.laser_id >= info.lasers) continue;  // unused VeloView padding (check_model_fit)
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
