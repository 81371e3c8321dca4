// `rig lidar decode` with the Ouster models (SPEC §7): OS-LEGACY on the shared capture writes one
// PCD and one JSON line per complete frame; bad metadata and a model/profile mismatch exit 2 naming
// the key.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ouster_test_support.hpp"
#include "rig_cli.hpp"
#include "sensor_rig/lidar/pcd.hpp"

namespace sensor_rig::lidar::ouster::test {
namespace {

namespace fs = std::filesystem;

using sensor_rig::test::CliRun;

std::string rig_bin() { return sensor_rig::test::rig_bin_or_empty(); }
CliRun run(const std::string& args) { return sensor_rig::test::run_rig(args); }

class OusterCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (rig_bin().empty() || !fs::exists(rig_bin())) GTEST_SKIP() << "RIG_BIN not set or missing";
    pcap_ = ouster_file("OS-1-32-G_v2.1.1_1024x10.pcap");
    meta_ = ouster_file("OS-1-32-G_v2.1.1_1024x10.json");
    if (!exists(pcap_) || !exists(meta_)) GTEST_SKIP() << "Ouster capture not found under " << data_dir();
    dir_ = fs::temp_directory_path() / ("rig_ouster_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::string pcap_, meta_;
  fs::path dir_;
};

TEST_F(OusterCli, LegacyCaptureGivesOneFrame) {
  const auto out = dir_ / "os1";
  const CliRun r = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + meta_ + " --out " +
                       out.string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::istringstream lines(r.out);
  std::string line;
  std::vector<nlohmann::json> scans;
  while (std::getline(lines, line)) scans.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(scans.size(), 1U) << r.out << r.err;
  const auto& j = scans[0];
  EXPECT_EQ(j.at("scan").get<int>(), 0);
  EXPECT_EQ(j.at("points").get<int>(), 27310);
  EXPECT_EQ(j.at("packets").get<int>(), 64);
  EXPECT_EQ(j.at("dropped").get<int>(), 0);
  EXPECT_EQ(j.at("missing_packets").get<int>(), 0);
  EXPECT_EQ(j.at("stamp_ns").get<long long>(), 3577133606620LL) << "first column's sensor time";
  const auto pts = read_pcd((out / "scan_000000.pcd").string());
  ASSERT_EQ(pts.size(), 27310U);
  for (const auto& p : pts) {
    ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    ASSERT_LT(p.ring, 32);
    ASSERT_LT(std::hypot(p.x, p.y, p.z), 1049.0F) << "LEGACY range is 20 bits of mm";
  }
  // --max-range keeps only the near points; --return last is accepted (one echo per pixel here).
  const CliRun near = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + meta_ +
                          " --max-range 5 --return last --out " + (dir_ / "near").string());
  ASSERT_EQ(near.code, 0) << near.err;
  const auto jn = nlohmann::json::parse(near.out);
  EXPECT_GT(jn.at("points").get<int>(), 0);
  EXPECT_LT(jn.at("points").get<int>(), 27310);
}

TEST_F(OusterCli, BadMetadataAndModelMismatchExit2) {
  const CliRun wrong = run("lidar decode --pcap " + pcap_ + " --model OS --metadata " + meta_ + " --out " +
                           (dir_ / "x").string());
  EXPECT_EQ(wrong.code, 2);
  EXPECT_NE(wrong.err.find("OS-LEGACY"), std::string::npos) << wrong.err;
  const CliRun none = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --out " + (dir_ / "y").string());
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("--metadata"), std::string::npos) << none.err;
  auto j = nlohmann::json::parse(read_text(meta_));
  j["data_format"]["columns_per_packet"] = "sixteen";
  const auto bad = dir_ / "bad.json";
  std::ofstream(bad) << j.dump();
  const CliRun b = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + bad.string() + " --out " +
                       (dir_ / "z").string());
  EXPECT_EQ(b.code, 2);
  EXPECT_NE(b.err.find("data_format.columns_per_packet"), std::string::npos) << b.err;
}

TEST_F(OusterCli, MetadataThatIsADirectoryOrEmptyExits2NamingIt) {
  const CliRun d = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + dir_.string() + " --out " +
                       (dir_ / "d").string());
  EXPECT_EQ(d.code, 2);
  EXPECT_NE(d.err.find("is a directory"), std::string::npos) << d.err;
  const auto empty = dir_ / "empty.json";
  std::ofstream(empty) << "  \n";
  const CliRun e = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + empty.string() + " --out " +
                       (dir_ / "e").string());
  EXPECT_EQ(e.code, 2);
  EXPECT_NE(e.err.find("is empty"), std::string::npos) << e.err;
}

TEST_F(OusterCli, WrongLayoutMetadataExits2) {
  // 16-beam metadata for the 32-beam capture: every packet has the wrong size, none could be
  // decoded: a clear error (exit 2) naming the packet size and the metadata, never silent.
  auto j = nlohmann::json::parse(read_text(meta_));
  j["data_format"]["pixels_per_column"] = 16;
  j["data_format"]["pixel_shift_by_row"] = std::vector<int>(16, 0);
  j["beam_altitude_angles"] = std::vector<double>(16, 0.0);
  j["beam_azimuth_angles"] = std::vector<double>(16, 0.0);
  const auto meta16 = dir_ / "m16.json";
  std::ofstream(meta16) << j.dump();
  const CliRun r = run("lidar decode --pcap " + pcap_ + " --model OS-LEGACY --metadata " + meta16.string() + " --out " +
                       (dir_ / "w").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_NE(r.err.find("data packets is 6464 bytes"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("m16.json"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace sensor_rig::lidar::ouster::test
