#include "sensor_rig/camera/calibration.hpp"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

namespace sensor_rig::camera {
namespace {

template <std::size_t N>
std::array<double, N> matrix(const YAML::Node& root, const char* key, std::size_t rows, std::size_t cols,
                             const std::string& name) {
  const auto m = root[key];
  if (!m || !m.IsMap()) throw CalibrationError(name + ": " + key + ": missing or not a map");
  const auto r = m["rows"].as<std::size_t>(0);
  const auto c = m["cols"].as<std::size_t>(0);
  const auto data = m["data"];
  if (r != rows || c != cols)
    throw CalibrationError(name + ": " + key + ": must be " + std::to_string(rows) + "x" + std::to_string(cols) + ", is " +
                           std::to_string(r) + "x" + std::to_string(c));
  if (!data || !data.IsSequence() || data.size() != N)
    throw CalibrationError(name + ": " + key + ".data: needs " + std::to_string(N) + " numbers");
  std::array<double, N> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = data[i].as<double>();
  return out;
}

}  // namespace

CameraInfo uncalibrated(std::uint32_t width, std::uint32_t height) {
  CameraInfo c;
  c.width = width;
  c.height = height;
  return c;
}

CameraInfo parse_calibration(std::string_view text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw CalibrationError(name + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!root.IsMap()) throw CalibrationError(name + ": not a camera_calibration YAML map");
  try {
    CameraInfo c;
    c.camera_name = root["camera_name"].as<std::string>("");
    const auto w = root["image_width"].as<std::int64_t>(0);
    const auto h = root["image_height"].as<std::int64_t>(0);
    if (w <= 0 || h <= 0 || w > 65535 || h > 65535)
      throw CalibrationError(name + ": image_width/image_height missing or out of range");
    c.width = static_cast<std::uint32_t>(w);
    c.height = static_cast<std::uint32_t>(h);
    c.k = matrix<9>(root, "camera_matrix", 3, 3, name);
    c.distortion_model = root["distortion_model"].as<std::string>("plumb_bob");
    const auto dn = root["distortion_coefficients"];
    if (!dn || !dn["data"] || !dn["data"].IsSequence()) throw CalibrationError(name + ": distortion_coefficients.data missing");
    for (const auto& v : dn["data"]) c.d.push_back(v.as<double>());
    const std::size_t n = c.d.size();
    const bool ok = (c.distortion_model == "plumb_bob" && n == 5) ||
                    (c.distortion_model == "rational_polynomial" && (n == 8 || n == 12 || n == 14)) ||
                    (c.distortion_model == "equidistant" && n == 4);
    if (!ok)
      throw CalibrationError(name + ": distortion_model '" + c.distortion_model + "' with " + std::to_string(n) +
                             " coefficients (plumb_bob: 5, rational_polynomial: 8, equidistant: 4)");
    c.r = root["rectification_matrix"] ? matrix<9>(root, "rectification_matrix", 3, 3, name)
                                       : std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (root["projection_matrix"]) {
      c.p = matrix<12>(root, "projection_matrix", 3, 4, name);
    } else {  // monocular default: P = [K | 0]
      for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j) c.p[i * 4 + j] = c.k[i * 3 + j];
    }
    if (c.k[8] == 0.0 || c.k[0] <= 0.0 || c.k[4] <= 0.0)
      throw CalibrationError(name + ": camera_matrix needs fx, fy > 0 and K[2][2] = 1");
    return c;
  } catch (const YAML::Exception& e) {
    throw CalibrationError(name + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

CameraInfo load_calibration(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CalibrationError("cannot read calibration " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return parse_calibration(text.str(), path);
}

std::string size_mismatch(const CameraInfo& info, std::uint32_t width, std::uint32_t height) {
  if (info.width == width && info.height == height) return {};
  return "calibration is for " + std::to_string(info.width) + "x" + std::to_string(info.height) + ", the camera runs " +
         std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace sensor_rig::camera
