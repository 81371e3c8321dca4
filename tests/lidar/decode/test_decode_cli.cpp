// `rig lidar decode` end to end (SPEC §7): JSON lines on stdout, one PCD per complete scan, exit
// codes for bad usage (2) and unreadable captures (1), and a truncated capture.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "rig_cli.hpp"
#include "sensor_rig/lidar/pcd.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::test {
namespace {

namespace fs = std::filesystem;

using sensor_rig::test::CliRun;

std::string rig_bin() { return sensor_rig::test::rig_bin_or_empty(); }
CliRun run(const std::string& args) { return sensor_rig::test::run_rig(args); }

class DecodeCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (rig_bin().empty() || !fs::exists(rig_bin())) GTEST_SKIP() << "RIG_BIN not set or missing";
    dir_ = fs::temp_directory_path() / ("rig_decode_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(DecodeCli, Vlp16CaptureMatchesVeloView) {
  const std::string pcap = velodyne_file("vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap");
  const std::string cal = velodyne_file("VeloView_VLP-16.xml");
  if (!exists(pcap) || !exists(cal)) GTEST_SKIP() << "capture not found under " << data_dir();
  const auto out = dir_ / "vlp16";
  const CliRun r = run("lidar decode --pcap " + pcap + " --model VLP-16 --calibration " + cal + " --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  std::vector<nlohmann::json> scans;
  while (std::getline(lines, line)) scans.push_back(nlohmann::json::parse(line));
  // VeloView: 52 frames = partial first + 50 complete + partial last. The complete ones are written.
  ASSERT_EQ(scans.size(), 50U);
  std::int64_t prev = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto& j = scans[i];
    ASSERT_EQ(j.size(), 6U) << line;
    EXPECT_EQ(j.at("scan").get<std::size_t>(), i);
    EXPECT_EQ(j.at("missing_packets").get<int>(), 0) << "the capture lost nothing";
    EXPECT_GT(j.at("stamp_ns").get<std::int64_t>(), prev);
    prev = j.at("stamp_ns").get<std::int64_t>();
    EXPECT_GE(j.at("packets").get<int>(), 38);
    EXPECT_LE(j.at("packets").get<int>(), 40);
    char name[32];
    std::snprintf(name, sizeof name, "scan_%06zu.pcd", i);
    const auto pts = read_pcd((out / name).string());
    EXPECT_EQ(pts.size(), j.at("points").get<std::size_t>()) << name;
  }
  // Scan 15 is VeloView's frame 16: 13,860 points, point 0 at (0.0801272, 6.04037, -1.61865) in
  // VeloView's x-right/y-forward frame.
  EXPECT_EQ(scans[15].at("points").get<int>(), 13860);
  const auto pts = read_pcd((out / "scan_000015.pcd").string());
  ASSERT_EQ(pts.size(), 13860U);
  EXPECT_NEAR(pts[0].x, 6.04037, 1e-3);
  EXPECT_NEAR(pts[0].y, -0.0801272, 1e-3);
  EXPECT_NEAR(pts[0].z, -1.61865, 1e-3);
  EXPECT_EQ(pts[0].intensity, 4.0F);
  // The stamp comes from the sensor clock with the pcap's hour.
  constexpr std::int64_t kHour = 3'600'000'000'000;
  EXPECT_EQ(scans[0].at("stamp_ns").get<std::int64_t>() / kHour, 1415069209LL * 1'000'000'000 / kHour);
  EXPECT_NE(r.err.find("dropped"), std::string::npos);
  EXPECT_EQ(fs::exists(out / "scan_000050.pcd"), false);
}

TEST_F(DecodeCli, CutAngleAndReturnOptions) {
  const std::string pcap = velodyne_file("hdl32e_veloview_monterey-first-100-packets.pcap");
  if (!exists(pcap)) GTEST_SKIP() << "capture not found under " << data_dir();
  const auto out = dir_ / "hdl";
  const CliRun r = run("lidar decode --pcap " + pcap + " --model HDL-32E --return dual --min-range 1 --max-range 50 "
                    "--cut-angle 180 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto pts = read_pcd((out / "scan_000002.pcd").string());
  ASSERT_GT(pts.size(), 30000U);
  // First block at/after 180°: pointing backwards (x < 0, y ~ 0).
  const double az = std::atan2(-static_cast<double>(pts[0].y), -static_cast<double>(pts[0].x)) * 180.0 / M_PI;
  EXPECT_NEAR(az, 0.0, 0.5);
  for (const auto& p : pts) {
    const double d = std::hypot(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
    ASSERT_GE(d, 0.99);
    ASSERT_LE(d, 50.01);
  }
}

TEST_F(DecodeCli, BadUsageExitsTwo) {
  const std::string pcap = velodyne_file("vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap");
  // Ouster models cannot decode without the sensor's metadata JSON.
  CliRun r = run("lidar decode --pcap " + pcap + " --model OS-LEGACY --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("metadata"), std::string::npos) << r.err;
  r = run("lidar decode --pcap " + pcap + " --model VLP-99 --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown model"), std::string::npos) << r.err;
  r = run("lidar decode --pcap " + pcap + " --model VLP-16 --return both --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  r = run("lidar decode --pcap " + pcap + " --model VLP-16 --cut-angle 400 --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  r = run("lidar decode --pcap /nonexistent.pcap --model VLP-16 --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  // Range bounds that are not finite numbers, bad azimuth words and FOVs: clear errors.
  for (const char* bad : {"--max-range nan", "--max-range inf", "--min-range nan", "--azimuth sideways",
                          "--fov 10", "--fov 10,400"}) {
    r = run("lidar decode --pcap " + pcap + " --model VLP-16 " + bad + " --out " + dir_.string());
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_FALSE(r.err.empty()) << bad;
    EXPECT_TRUE(r.out.empty()) << bad;
  }
  r = run("lidar decode --pcap " + pcap + " --model VLP-16 --max-range nan --out " + dir_.string());
  EXPECT_NE(r.err.find("not a finite number"), std::string::npos) << r.err;
  const auto bad_cal = dir_ / "bad.yaml";
  std::ofstream(bad_cal) << "lasers:\n- {laser_id: 0, vert_correction: x}\n";
  r = run("lidar decode --pcap " + pcap + " --model VLP-16 --calibration " + bad_cal.string() + " --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.yaml:2:"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
}

// A calibration made for another model: exit 2 naming the file and the mismatch, nothing decoded.
TEST_F(DecodeCli, CalibrationOfAnotherModelExitsTwo) {
  const std::string vlp16 = velodyne_file("vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap");
  const std::string hdl32 = velodyne_file("hdl32e_veloview_monterey-first-100-packets.pcap");
  const std::string vlp32c_cal = velodyne_file("ros_velodyne_VeloView-VLP-32C.yaml");
  if (!exists(vlp16) || !exists(hdl32) || !exists(vlp32c_cal)) GTEST_SKIP() << "captures not found under " << data_dir();
  CliRun r = run("lidar decode --pcap " + vlp16 + " --model VLP-16 --calibration " + vlp32c_cal + " --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(vlp32c_cal + ": num_lasers 32 does not match VLP-16"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  r = run("lidar decode --pcap " + hdl32 + " --model HDL-32E --calibration " + vlp32c_cal + " --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(vlp32c_cal + ": distance_resolution 0.004 m does not match HDL-32E"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
  // A small generated file: 32 lasers for the VLP-16.
  const auto gen = dir_ / "thirty_two.yaml";
  {
    std::ofstream f(gen);
    f << "lasers:\n";
    for (int i = 0; i < 32; ++i) f << "- {laser_id: " << i << ", vert_correction: 0." << i << "}\n";
  }
  r = run("lidar decode --pcap " + vlp16 + " --model VLP-16 --calibration " + gen.string() + " --out " + dir_.string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("thirty_two.yaml: num_lasers 32 does not match VLP-16"), std::string::npos) << r.err;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator{}), 1);  // no PCD written
}

TEST_F(DecodeCli, CorruptAndTruncatedCaptures) {
  const auto junk = dir_ / "junk.pcap";
  std::ofstream(junk) << std::string(100, 'x');
  CliRun r = run("lidar decode --pcap " + junk.string() + " --model VLP-16 --out " + (dir_ / "o1").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("cannot read pcap"), std::string::npos) << r.err;

  const std::string pcap = velodyne_file("vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap");
  if (!exists(pcap)) GTEST_SKIP() << "capture not found under " << data_dir();
  std::string bytes = read_text(pcap);
  bytes.resize(bytes.size() / 3 + 77);  // ends inside a record
  const auto cut = dir_ / "cut.pcap";
  std::ofstream(cut, std::ios::binary) << bytes;
  r = run("lidar decode --pcap " + cut.string() + " --model VLP-16 --out " + (dir_ / "o2").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("truncated"), std::string::npos) << r.err;
  const auto n = static_cast<std::size_t>(std::count(r.out.begin(), r.out.end(), '\n'));
  EXPECT_GE(n, 14U);
  EXPECT_LE(n, 17U);
}

}  // namespace
}  // namespace sensor_rig::lidar::test
