// `rig up` starts each LIDAR's mock as `rig lidar replay ...`: the command line must describe the
// sensor the driver decodes (model, port, return mode, calibration) or the two disagree silently.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "rig_config.hpp"
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

}  // namespace
}  // namespace sensor_rig::rig
