// Decoding the shared captures reproduces VeloView's reference frames (the *.test files shipped
// beside them): frame count, point counts per listed frame, and every listed point.
// VeloView's frame is x right, y forward, z up; REP 103 is x forward, y left: x = y_vv, y = -x_vv.
// VeloView numbers the partial scan before the first wrap frame 0 and also emits the trailing
// partial scan, so the decoder runs with emit_partial_scans and the tail is flushed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "test_support.hpp"

namespace sensor_rig::lidar::test {
namespace {

struct RefPoint {
  std::size_t index;
  double x, y, z, intensity;
};
struct Reference {
  std::size_t frame_count = 0;
  std::map<std::size_t, std::size_t> point_counts;
  std::map<std::size_t, std::vector<RefPoint>> points;
};

Reference parse_reference(const std::string& text) {
  Reference r;
  std::istringstream in(text);
  std::string key;
  std::size_t frame = 0;
  while (in >> key) {
    if (key == "frame_count") {
      in >> r.frame_count;
    } else if (key == "frame") {
      in >> frame;
    } else if (key == "point_count") {
      in >> r.point_counts[frame];
    } else if (key == "point_values") {
      RefPoint p{};
      double last = 0;  // sixth column: 0 in every listed point, not compared
      in >> p.index >> p.x >> p.y >> p.z >> p.intensity >> last;
      r.points[frame].push_back(p);
    } else {
      ADD_FAILURE() << "unknown key in reference: " << key;
      break;
    }
  }
  return r;
}

struct Case {
  const char* pcap;
  const char* calibration;
  const char* reference;
  velodyne::Model model;
};

class VeloViewReference : public ::testing::TestWithParam<Case> {};

TEST_P(VeloViewReference, FramesPointCountsAndPoints) {
  const Case c = GetParam();
  const std::string pcap = velodyne_file(c.pcap);
  const std::string cal = velodyne_file(c.calibration);
  const std::string ref = velodyne_file(c.reference);
  if (!exists(pcap) || !exists(cal) || !exists(ref)) {
    GTEST_SKIP() << "capture/reference not found under " << data_dir() << " (set RIG_TEST_DATA)";
  }
  const Reference r = parse_reference(read_text(ref));
  ASSERT_GT(r.frame_count, 0U);
  ASSERT_FALSE(r.points.empty());

  velodyne::DecoderConfig cfg;
  cfg.model = c.model;
  cfg.calibration = velodyne::parse_calibration(read_text(cal), cal);
  cfg.emit_partial_scans = true;
  // VeloView places each firing sequence (not each laser) at its interpolated azimuth.
  cfg.interpolation = velodyne::AzimuthInterpolation::kPerSequence;
  const auto scans = decode_capture(pcap, cfg);

  ASSERT_EQ(scans.size(), r.frame_count);
  for (std::size_t i = 0; i < scans.size(); ++i) EXPECT_EQ(scans[i].seq, i);
  for (const auto& [frame, count] : r.point_counts) {
    EXPECT_EQ(scans[frame].points.size(), count) << "frame " << frame;
  }
  double worst = 0.0;
  for (const auto& [frame, pts] : r.points) {
    const auto& scan = scans[frame];
    for (const auto& p : pts) {
      ASSERT_LT(p.index, scan.points.size()) << "frame " << frame;
      const auto& q = scan.points[p.index];
      const double range = std::hypot(p.x, p.y, p.z);
      const double tol = 5e-4 + range * 5e-6;  // float rounding; VeloView matches to < 0.1 mm
      EXPECT_NEAR(q.x, p.y, tol) << "frame " << frame << " point " << p.index;
      EXPECT_NEAR(q.y, -p.x, tol) << "frame " << frame << " point " << p.index;
      EXPECT_NEAR(q.z, p.z, tol) << "frame " << frame << " point " << p.index;
      EXPECT_EQ(q.intensity, static_cast<float>(p.intensity)) << "frame " << frame << " point " << p.index;
      const double qx = static_cast<double>(q.x), qy = static_cast<double>(q.y), qz = static_cast<double>(q.z);
      worst = std::max({worst, std::abs(qx - p.y), std::abs(qy + p.x), std::abs(qz - p.z)});
    }
  }
  std::printf("largest deviation from VeloView: %.6f m\n", worst);
  // Scan stamps increase; point times stay within one rotation (50..200 ms at 1200..300 rpm).
  for (std::size_t i = 1; i < scans.size(); ++i) EXPECT_GT(scans[i].stamp, scans[i - 1].stamp);
  for (std::size_t i = 1; i + 1 < scans.size(); ++i) {
    std::uint32_t tmax = 0;
    for (const auto& q : scans[i].points) tmax = std::max(tmax, q.t);
    EXPECT_LT(tmax, 200'000'000U) << "scan " << i;
    EXPECT_GT(tmax, 40'000'000U) << "scan " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Captures, VeloViewReference,
    ::testing::Values(Case{"vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap", "VeloView_VLP-16.xml",
                           "VeloView_vlp-16.test", velodyne::Model::kVLP16},
                      Case{"hdl32e_veloview_monterey-first-100-packets.pcap", "VeloView_HDL-32.xml",
                           "VeloView_monterey.test", velodyne::Model::kHDL32E}),
    [](const auto& i) { return std::string(i.param.model == velodyne::Model::kVLP16 ? "VLP16" : "HDL32E"); });

}  // namespace
}  // namespace sensor_rig::lidar::test
