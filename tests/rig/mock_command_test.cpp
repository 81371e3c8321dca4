// `rig up` starts each LIDAR's mock as `rig lidar replay ...`: the command line must describe the
// sensor the driver decodes (model, port, return mode, calibration) or the two disagree silently.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rig_config.hpp"
#include "sensor_rig/common/errors.hpp"
#include "rig_runner.hpp"

namespace sensor_rig::rig {
namespace {

// The value that follows `flag` in argv, or "" when the flag is absent.
std::string value_of(const std::vector<std::string>& argv, const std::string& flag) {
  const auto it = std::find(argv.begin(), argv.end(), flag);
  return it == argv.end() || it + 1 == argv.end() ? std::string{} : *(it + 1);
}

bool has(const std::vector<std::string>& argv, const std::string& flag) {
  return std::find(argv.begin(), argv.end(), flag) != argv.end();
}

LidarConfig synthetic(const std::string& model, lidar::ReturnSelection returns) {
  LidarConfig l;
  l.name = "l";
  l.model = model;
  l.host = "127.0.0.1";
  l.port = 2399;
  l.returns = returns;
  l.mock.kind = LidarMockConfig::Kind::kSynthetic;
  l.mock.rpm = 600;
  return l;
}

TEST(LidarMockCommand, SyntheticVelodyneCarriesModelPortAndReturnMode) {
  const auto argv = lidar_mock_command("rig", synthetic("VLP-16", lidar::ReturnSelection::kDual));
  ASSERT_GE(argv.size(), 3u);
  EXPECT_EQ(argv[1], "lidar");
  EXPECT_EQ(argv[2], "replay");
  EXPECT_EQ(value_of(argv, "--synthetic"), "VLP-16");
  EXPECT_EQ(value_of(argv, "--to"), "127.0.0.1:2399");
  EXPECT_EQ(value_of(argv, "--return"), "dual");
  EXPECT_EQ(value_of(argv, "--rpm"), "600");
  EXPECT_FALSE(has(argv, "--pcap"));
}

TEST(LidarMockCommand, HesaiLastReturnIsPassedOn) {
  EXPECT_EQ(value_of(lidar_mock_command("rig", synthetic("Pandar40P", lidar::ReturnSelection::kLast)), "--return"), "last");
}

TEST(LidarMockCommand, OusterTakesItsEchoesFromTheProfileAndGetsTheDriversMetadata) {
  auto l = synthetic("OS-LEGACY", lidar::ReturnSelection::kStrongest);
  l.metadata = "/tmp/os.json";
  const auto argv = lidar_mock_command("rig", l);
  EXPECT_FALSE(has(argv, "--return"));
  EXPECT_EQ(value_of(argv, "--metadata"), "/tmp/os.json");
}

TEST(LidarMockCommand, ReplayAndNone) {
  LidarConfig l = synthetic("VLP-16", lidar::ReturnSelection::kStrongest);
  l.mock.kind = LidarMockConfig::Kind::kReplay;
  l.mock.pcap = "/data/x.pcap";
  l.mock.loop = true;
  const auto argv = lidar_mock_command("rig", l);
  EXPECT_EQ(value_of(argv, "--pcap"), "/data/x.pcap");
  EXPECT_TRUE(has(argv, "--loop"));
  EXPECT_FALSE(has(argv, "--synthetic"));
  EXPECT_FALSE(has(argv, "--position-port"));  // none configured: the capture's are skipped
  l.mock.kind = LidarMockConfig::Kind::kNone;
  EXPECT_TRUE(lidar_mock_command("rig", l).empty());
}

// A capture's position packets (GPRMC, PPS) reach the driver's position port, as the synthetic
// sensor's do.
TEST(LidarMockCommand, PositionPortForReplayAndSynthetic) {
  LidarConfig l = synthetic("VLP-16", lidar::ReturnSelection::kStrongest);
  l.position_port = 8318;
  EXPECT_EQ(value_of(lidar_mock_command("rig", l), "--position-port"), "8318");
  l.mock.kind = LidarMockConfig::Kind::kReplay;
  l.mock.pcap = "/data/x.pcap";
  EXPECT_EQ(value_of(lidar_mock_command("rig", l), "--position-port"), "8318");
}

// `mock.phase_deg` (phase lock) reaches the mock's command line; where it cannot hold, the config
// says so at its line.
TEST(LidarMockCommand, PhaseLockFromTheConfig) {
  const auto path = (std::filesystem::temp_directory_path() / ("phase_" + std::to_string(::getpid()) + ".yaml")).string();
  const auto load = [&](const std::string& yaml) {
    std::ofstream(path) << yaml;
    return load_rig_config(path);
  };
  const auto cfg = load(
      "rig: {name: t}\nlidars:\n"
      "  - {name: a, model: VLP-32C, port: 2368, mock: {kind: synthetic, rpm: 600, phase_deg: 90}}\n"
      "  - {name: b, model: Pandar40P, port: 2369, mock: {kind: synthetic}}\n");
  ASSERT_EQ(cfg.lidars.size(), 2u);
  EXPECT_EQ(value_of(lidar_mock_command("rig", cfg.lidars[0]), "--phase-lock").substr(0, 4), "90.0");
  EXPECT_FALSE(has(lidar_mock_command("rig", cfg.lidars[1]), "--phase-lock"));  // free running
  EXPECT_NE(describe(cfg).find("phase-locked 90 deg"), std::string::npos) << describe(cfg);
  try {
    (void)load(
        "rig: {name: t}\nlidars:\n"
        "  - {name: a, model: VLP-16, port: 2368, mock: {kind: synthetic, rpm: 700, phase_deg: 10}}\n"
        "  - {name: b, model: VLP-16, port: 2369, mock: {kind: replay, pcap: " + path + ", phase_deg: 10}}\n"
        "  - {name: c, model: VLP-16, port: 2370, mock: {kind: synthetic, phase_deg: 360}}\n");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path + ":3:"), std::string::npos) << m;
    EXPECT_NE(m.find("whole number of turns per second"), std::string::npos) << m;
    EXPECT_NE(m.find(path + ":4:"), std::string::npos) << m;
    EXPECT_NE(m.find("applies to a synthetic mock"), std::string::npos) << m;
    EXPECT_NE(m.find(path + ":5:"), std::string::npos) << m;
    EXPECT_NE(m.find("lidars[2].mock.phase_deg"), std::string::npos) << m;
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace sensor_rig::rig
