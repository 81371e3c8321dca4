#pragma once
// ROS camera_calibration YAML (camera_info_manager's format) -> a plain CameraInfo. Pure parsing:
// text in, struct out; the caller reads the file. An empty calibration is "uncalibrated" as ROS
// has it: K, R, P all zero, no distortion model.
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::camera {

struct CalibrationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct CameraInfo {
  std::string camera_name;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::string distortion_model;  // plumb_bob | rational_polynomial | equidistant; "" uncalibrated
  std::vector<double> d;
  std::array<double, 9> k{};   // row-major 3x3 intrinsics
  std::array<double, 9> r{};   // rectification
  std::array<double, 12> p{};  // 3x4 projection
  [[nodiscard]] bool calibrated() const noexcept { return k[8] != 0.0; }
};

// Uncalibrated info of the given size (ROS: K all zero means uncalibrated).
CameraInfo uncalibrated(std::uint32_t width, std::uint32_t height);

// Parses the YAML text; `name` (the file) prefixes errors. Throws CalibrationError on malformed
// text, wrong matrix sizes, an unknown distortion model or a distortion count that does not fit it.
CameraInfo parse_calibration(std::string_view yaml_text, const std::string& name);
// Reads and parses a file; throws CalibrationError (also when unreadable).
CameraInfo load_calibration(const std::string& path);
// Empty when the calibration fits a width x height image; else the reason.
std::string size_mismatch(const CameraInfo& info, std::uint32_t width, std::uint32_t height);

}  // namespace sensor_rig::camera
