#include <gtest/gtest.h>

#include "sensor_rig/camera/calibration.hpp"

namespace sensor_rig::camera {
namespace {

constexpr const char* kYaml = R"(image_width: 1920
image_height: 1200
camera_name: front_narrow
camera_matrix:
  rows: 3
  cols: 3
  data: [1400.5, 0, 960.25, 0, 1401.5, 600.75, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.1, 0.02, 0.001, -0.002, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [1390, 0, 955, 0, 0, 1391, 601, 0, 0, 0, 1, 0]
)";

TEST(Calibration, ParsesRosCameraCalibrationYaml) {
  const auto c = parse_calibration(kYaml, "front.yaml");
  EXPECT_EQ(c.camera_name, "front_narrow");
  EXPECT_EQ(c.width, 1920u);
  EXPECT_EQ(c.height, 1200u);
  EXPECT_EQ(c.distortion_model, "plumb_bob");
  ASSERT_EQ(c.d.size(), 5u);
  EXPECT_DOUBLE_EQ(c.d[0], -0.1);
  EXPECT_DOUBLE_EQ(c.k[0], 1400.5);
  EXPECT_DOUBLE_EQ(c.k[2], 960.25);
  EXPECT_DOUBLE_EQ(c.k[5], 600.75);
  EXPECT_DOUBLE_EQ(c.k[8], 1.0);
  EXPECT_DOUBLE_EQ(c.r[4], 1.0);
  EXPECT_DOUBLE_EQ(c.p[0], 1390.0);
  EXPECT_DOUBLE_EQ(c.p[10], 1.0);
  EXPECT_TRUE(c.calibrated());
  EXPECT_TRUE(size_mismatch(c, 1920, 1200).empty());
  EXPECT_NE(size_mismatch(c, 1280, 720).find("1920x1200"), std::string::npos);
}

TEST(Calibration, UncalibratedIsKAllZeroAsRos) {
  const auto c = uncalibrated(640, 480);
  EXPECT_FALSE(c.calibrated());
  for (double v : c.k) EXPECT_EQ(v, 0.0);
  for (double v : c.p) EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(c.d.empty());
  EXPECT_EQ(c.width, 640u);
}

TEST(Calibration, MonocularDefaultsForRAndP) {
  std::string y = kYaml;
  y = y.substr(0, y.find("rectification_matrix"));
  const auto c = parse_calibration(y, "mono.yaml");
  EXPECT_DOUBLE_EQ(c.r[0], 1.0);
  EXPECT_DOUBLE_EQ(c.r[8], 1.0);
  EXPECT_DOUBLE_EQ(c.p[0], c.k[0]);
  EXPECT_DOUBLE_EQ(c.p[2], c.k[2]);
  EXPECT_DOUBLE_EQ(c.p[3], 0.0);
}

TEST(Calibration, BadFilesSayWhy) {
  const auto fails_with = [](const std::string& text, const char* needle) {
    try {
      (void)parse_calibration(text, "bad.yaml");
      ADD_FAILURE() << "no error for: " << needle;
    } catch (const CalibrationError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  std::string y = kYaml;
  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = y;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  fails_with(replace("data: [-0.1, 0.02, 0.001, -0.002, 0.0]", "data: [-0.1, 0.02]"), "plumb_bob: 5");
  fails_with(replace("distortion_model: plumb_bob", "distortion_model: fisheye9"), "fisheye9");
  fails_with(replace("data: [1400.5, 0, 960.25, 0, 1401.5, 600.75, 0, 0, 1]", "data: [1, 2, 3]"), "camera_matrix");
  fails_with(replace("image_width: 1920", "image_width: -3"), "image_width");
  fails_with(replace("  rows: 3\n  cols: 4", "  rows: 4\n  cols: 3"), "projection_matrix");
  fails_with("image_width: [", "bad.yaml");
  fails_with("- a\n- b\n", "not a camera_calibration");
  EXPECT_THROW((void)load_calibration("/nonexistent/calib.yaml"), CalibrationError);
}

}  // namespace
}  // namespace sensor_rig::camera
