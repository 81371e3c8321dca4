// `rig lidar decode --model Pandar40P|PandarXT32` end to end: JSON lines, PCD files, calibration
// errors (exit 2 with file:line), packets of another model counted as drops.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "rig_cli.hpp"
#include "sensor_rig/lidar/pcd.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::hesai::test {
namespace {

namespace fs = std::filesystem;

using sensor_rig::test::CliRun;

std::string rig_bin() { return sensor_rig::test::rig_bin_or_empty(); }
CliRun run(const std::string& args) { return sensor_rig::test::run_rig(args); }

std::vector<nlohmann::json> json_lines(const std::string& out) {
  std::vector<nlohmann::json> v;
  std::istringstream s(out);
  std::string line;
  while (std::getline(s, line))
    if (!line.empty()) v.push_back(nlohmann::json::parse(line));
  return v;
}

class HesaiDecodeCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (rig_bin().empty() || !fs::exists(rig_bin())) GTEST_SKIP() << "RIG_BIN not set or missing";
    pcap_ = hesai_file("pandar40p_nebula_1673400149412331409.pcap");
    cal_ = hesai_file("nebula_Pandar40P.csv");
    if (!exists(pcap_) || !exists(cal_)) GTEST_SKIP() << "Hesai capture absent: " << pcap_;
    dir_ = fs::temp_directory_path() / ("rig_hesai_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::string pcap_, cal_;
  fs::path dir_;
};

TEST_F(HesaiDecodeCli, Pandar40PDualWithCalibration) {
  const auto out = dir_ / "dual";
  const auto r = run("lidar decode --pcap " + pcap_ + " --model Pandar40P --calibration " + cal_ +
                     " --return dual --min-range 0.3 --max-range 200 --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = json_lines(r.out);
  ASSERT_EQ(lines.size(), 2U) << r.out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    EXPECT_EQ(lines[i]["scan"], i);
    EXPECT_EQ(lines[i]["dropped"], 0);
    EXPECT_GE(lines[i]["packets"].get<int>(), 360);
    const auto pcd = out / ("scan_00000" + std::to_string(i) + ".pcd");
    ASSERT_TRUE(fs::exists(pcd));
    EXPECT_EQ(read_pcd(pcd.string()).size(), lines[i]["points"].get<std::size_t>());
  }
  EXPECT_EQ(lines[1]["points"], 56762) << "nebula's ground-truth scan";
  // Sensor clock (not synced): 2017-09-06 16:19:46 UTC + the packet's µs.
  EXPECT_EQ(lines[0]["stamp_ns"].get<std::int64_t>() / 1'000'000'000, 1504714786);
  EXPECT_NE(r.err.find("decoded 2 scans from 1439 data packets (0 dropped"), std::string::npos) << r.err;
}

TEST_F(HesaiDecodeCli, BuiltInCalibrationAndCutAngle) {
  const auto r = run("lidar decode --pcap " + pcap_ + " --model Pandar40P --cut-angle 180 --out " + (dir_ / "s").string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto lines = json_lines(r.out);
  ASSERT_EQ(lines.size(), 3U) << r.out;
  EXPECT_GT(lines[1]["points"].get<int>(), 40'000);
}

TEST_F(HesaiDecodeCli, CalibrationErrorNamesTheLine) {
  const auto bad = dir_ / "bad.csv";
  std::ofstream(bad) << "Laser id,Elevation,Azimuth\n1,14.7,-1.042\n2,oops,-1.042\n";
  const auto r = run("lidar decode --pcap " + pcap_ + " --model Pandar40P --calibration " + bad.string() +
                     " --out " + (dir_ / "x").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.csv:3: elevation 'oops' is not a number"), std::string::npos) << r.err;
}

TEST_F(HesaiDecodeCli, AnotherModelsCaptureExits2) {
  // Not one packet of the capture has the model's size: a usage error naming the size, not an
  // empty "successful" decode.
  const auto r = run("lidar decode --pcap " + pcap_ + " --model PandarXT32 --out " + (dir_ / "xt").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_NE(r.err.find("every one of the 1439 data packets is 1262 bytes, which model PandarXT32"), std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace sensor_rig::lidar::hesai::test
