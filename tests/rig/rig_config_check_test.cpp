// `rig config check` as a user runs it: each kind of mistake exits 2 with `file:line:col: key:`
// pointing at the offending line, all mistakes of a file are reported at once, a calibration made
// for another model is refused, and every shipped config (config/*.yaml) validates.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "rig_cli.hpp"

namespace sensor_rig::test {
namespace {

namespace fs = std::filesystem;

std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v != nullptr ? v : fallback;
}

class ConfigCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    if (rig_bin_or_empty().empty() || !fs::exists(rig_bin_or_empty())) GTEST_SKIP() << "RIG_BIN not set or missing";
    dir_ = fs::temp_directory_path() / ("rig_config_check_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path dir_;
};

// Lines of the base config, numbered for the expectations below.
const std::vector<std::string> kBase = {
    "rig:",                        // 1
    "  name: check",               // 2
    "lidars:",                     // 3
    "  - name: front",             // 4
    "    model: VLP-16",           // 5
    "    port: 2368",              // 6
    "    min_range: 0.5",          // 7
    "  - name: rear",              // 8
    "    model: HDL-32E",          // 9
    "    port: 2369",              // 10
};

std::string with(std::vector<std::string> lines, const std::vector<std::pair<int, std::string>>& replace) {
  for (const auto& [line, text] : replace) lines[static_cast<std::size_t>(line - 1)] = text;
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

// The `file:LINE:COL: KEY:` error lines of the output, as "LINE KEY".
std::vector<std::string> located(const std::string& err, const std::string& file) {
  std::vector<std::string> out;
  const std::regex re(std::regex_replace(file, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                      R"(:(\d+):(\d+): ([^:]+): )");
  for (std::sregex_iterator it(err.begin(), err.end(), re), end; it != end; ++it)
    out.push_back((*it)[1].str() + " " + (*it)[3].str());
  return out;
}

TEST_F(ConfigCheck, TheBaseConfigIsValid) {
  const auto r = run_rig("config check " + write("base.yaml", with(kBase, {})));
  EXPECT_EQ(r.code, 0) << r.err;
}

// What a real Velodyne's scans are sized for is said (the slowest speed unless `rpm` says), and a
// sensor's `rpm` is its synthetic mock's speed when the mock does not give its own.
TEST_F(ConfigCheck, TheSpeedScansAreSizedForIsShownAndSetsTheMock) {
  auto r = run_rig("config check " + write("unsaid.yaml", with(kBase, {})));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("300 rpm (not said: sized for the slowest"), std::string::npos) << r.out;
  r = run_rig("config check " + write("said.yaml", with(kBase, {{7, "    rpm: 600"}})));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(", 600 rpm\n"), std::string::npos) << r.out;
  r = run_rig("config check " + write("mock.yaml", with(kBase, {{7, "    rpm: 900\n    mock: {kind: synthetic}"}})));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("[mock: synthetic 900 rpm"), std::string::npos) << r.out;
}

TEST_F(ConfigCheck, EachMistakeExitsTwoAtItsLine) {
  struct Case {
    const char* what;
    std::vector<std::pair<int, std::string>> edit;
    const char* where;    // "LINE KEY" of the one error
    const char* message;  // part of the message
  };
  const Case cases[] = {
      {"unknown key", {{7, "    min_rnage: 0.5"}}, "7 lidars[0].min_rnage", "unknown key"},
      {"wrong type", {{6, "    port: front"}}, "6 lidars[0].port", ""},
      {"out of range", {{7, "    min_range: 50"}}, "7 lidars[0].min_range", ""},
      {"duplicate name", {{8, "  - name: front"}}, "8 lidars[1].name", "duplicate"},
      {"duplicate port", {{10, "    port: 2368"}}, "10 lidars[1].port", "used twice"},
      {"duplicate imu port (named as written)",
       {{9, "    model: OS-LEGACY"}, {10, "    port: 7502\n    imu_port: 2368\n    mock: {kind: synthetic, rpm: 600}"}},
       "11 lidars[1].imu_port",
       "used twice"},
      {"Cyclone thread priority out of range", {{2, "  name: check\n  dds:\n    realtime_priority: 120"}},
       "4 rig.dds.realtime_priority", ""},
      {"rotation speed below the slowest a sensor turns", {{7, "    rpm: 250"}}, "7 lidars[0].rpm", ""},
      {"rpm on an Ouster (its lidar_mode says)",
       {{9, "    model: OS-LEGACY"}, {10, "    port: 7502\n    rpm: 600\n    mock: {kind: synthetic}"}},
       "11 lidars[1].rpm",
       "lidar_mode"},
      {"the sensor's rpm and its synthetic mock's disagree",
       {{7, "    rpm: 300\n    mock: {kind: synthetic,\n           rpm: 600}"}},
       "9 lidars[0].mock.rpm",
       "give one of them"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string file = write(std::string("case_") + std::to_string(&c - cases) + ".yaml", with(kBase, c.edit));
    const auto r = run_rig("config check " + file);
    EXPECT_EQ(r.code, 2) << r.err;
    const auto errors = located(r.err, file);
    ASSERT_EQ(errors.size(), 1u) << r.err;
    EXPECT_EQ(errors[0], c.where) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
  }
}

TEST_F(ConfigCheck, AllMistakesAtOnce) {
  const std::string file = write("all.yaml", with(kBase, {{2, "  nmae: check"},
                                                         {6, "    port: front"},
                                                         {7, "    min_range: 50"},
                                                         {8, "  - name: front"}}) +
                                                 "  - name: side\n    model: VLP-16\n    port: 2369\n");
  const auto r = run_rig("config check " + file);
  EXPECT_EQ(r.code, 2);
  auto errors = located(r.err, file);
  std::sort(errors.begin(), errors.end());
  EXPECT_EQ(errors, (std::vector<std::string>{"13 lidars[2].port", "2 rig.nmae", "6 lidars[0].port",
                                              "7 lidars[0].min_range", "8 lidars[1].name"}))
      << r.err;
}

// A lidar whose calibration was made for another model: refused at the calibration key.
TEST_F(ConfigCheck, CalibrationOfAnotherModel) {
  std::string thirty_two = "lasers:\n";
  for (int i = 0; i < 32; ++i) thirty_two += "- {laser_id: " + std::to_string(i) + ", vert_correction: 0.0" + std::to_string(i % 10) + "}\n";
  write("cal32.yaml", thirty_two);
  const std::string file = write("cal.yaml", with(kBase, {{7, "    calibration: cal32.yaml"}}));
  auto r = run_rig("config check " + file);
  EXPECT_EQ(r.code, 2);
  auto errors = located(r.err, file);
  ASSERT_EQ(errors.size(), 1u) << r.err;
  EXPECT_EQ(errors[0], "7 lidars[0].calibration") << r.err;
  EXPECT_NE(r.err.find("num_lasers 32 does not match VLP-16"), std::string::npos) << r.err;
  // The same file suits the HDL-32E (32 lasers, resolution not stated = the model's).
  r = run_rig("config check " + write("cal_ok.yaml", with(kBase, {}) + "    calibration: cal32.yaml\n"));
  EXPECT_EQ(r.code, 0) << r.err;

  const fs::path shared = fs::path(env_or("RIG_TEST_DATA", "../shared/data")) / "lidar/velodyne";
  if (!fs::exists(shared / "ros_velodyne_VeloView-VLP-32C.yaml")) GTEST_SKIP() << "no calibration files under " << shared;
  // A VLP-32C file (4 mm counts) on the HDL-32E (2 mm) would double every range.
  const std::string hdl =
      write("hdl.yaml", with(kBase, {}) + "    calibration: " + (shared / "ros_velodyne_VeloView-VLP-32C.yaml").string() + "\n");
  r = run_rig("config check " + hdl);
  EXPECT_EQ(r.code, 2);
  errors = located(r.err, hdl);
  ASSERT_EQ(errors.size(), 1u) << r.err;
  EXPECT_EQ(errors[0], "11 lidars[1].calibration") << r.err;
  EXPECT_NE(r.err.find("distance_resolution 0.004 m does not match HDL-32E"), std::string::npos) << r.err;
}

TEST_F(ConfigCheck, EveryShippedConfigValidates) {
  const fs::path config_dir = fs::path(env_or("RIG_SOURCE_DIR", ".")) / "config";
  int checked = 0;
  for (const auto& e : fs::directory_iterator(config_dir)) {
    if (e.path().extension() != ".yaml") continue;
    std::ifstream in(e.path());
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    // replay_rig.yaml names the shared captures beside the clone (not part of the project).
    if (text.find("shared/data") != std::string::npos && !fs::exists(config_dir / "../../shared/data/lidar")) {
      std::cout << "skipped " << e.path() << ": the shared captures it names are absent\n";
      continue;
    }
    const auto r = run_rig("config check " + e.path().string());
    EXPECT_EQ(r.code, 0) << e.path() << "\n" << r.err;
    ++checked;
  }
  EXPECT_GE(checked, 1) << "no config/*.yaml validated";
}

// fusion: (issue 11) every LIDAR needs its pose in base_link; the pose and the section are
// validated like the rest, each mistake at its own line; a valid one is named in the summary.
TEST_F(ConfigCheck, FusionMistakesAtTheirLines) {
  const std::string file = write("fusion.yaml", with(kBase, {{7, "    min_range: 0.5\n    extrinsics: {x: 1.4, z: 1.9, pitch_deg: 95}"}}) +
                                                    "fusion:\n"                                                  // 12
                                                    "  enable: true\n"                                           // 13
                                                    "  crop_box: {x_min: 4, x_max: -1, y_min: -1, y_max: 1, z_min: 0, z_max: 2}\n"  // 14
                                                    "  timeout_ms: 80\n"                                         // 15
                                                    "  voxel: 0.1\n");                                           // 16
  const auto r = run_rig("config check " + file);
  EXPECT_EQ(r.code, 2);
  auto errors = located(r.err, file);
  std::sort(errors.begin(), errors.end());
  EXPECT_EQ(errors, (std::vector<std::string>{"14 fusion.crop_box.x_max", "15 fusion.timeout_ms", "16 fusion.voxel",
                                              "8 lidars[0].extrinsics.pitch_deg", "9 lidars[1].extrinsics"}))
      << r.err;
  EXPECT_NE(r.err.find("fusion is enabled: give this LIDAR's pose in base_link"), std::string::npos) << r.err;

  const std::string good = write("fusion_ok.yaml", with(kBase, {{7, "    extrinsics: {x: 1.4, z: 1.9}"}}) +
                                                       "    extrinsics: {x: -0.5, z: 1.8, yaw_deg: 180}\n"
                                                       "fusion: {enable: true, voxel_leaf: 0.1}\n");
  const auto ok = run_rig("config check " + good);
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.out.find("fusion: 2 lidars -> /sensors/lidar/fused/points in base_link"), std::string::npos) << ok.out;
}

// A trigger group fired by a LIDAR crossing (issue 12: the stereo pair): one trigger fires all
// members, so they must name the same LIDAR, azimuth and latency; each conflict at its key.
TEST_F(ConfigCheck, TriggerGroupOnALidarMembersAgree) {
  const std::string cameras =
      "cameras:\n"                                                       // 11
      "  - name: stereo_left\n"                                          // 12
      "    device: sl\n"                                                 // 13
      "    trigger: {group: stereo, lidar: front, azimuth_deg: 0}\n"     // 14
      "  - name: stereo_right\n"                                         // 15
      "    device: sr\n";                                                // 16
  const auto right = [&](const std::string& trigger) { return with(kBase, {}) + cameras + "    trigger: " + trigger + "\n"; };
  const auto ok = run_rig("config check " + write("group_ok.yaml", right("{group: stereo, lidar: front, azimuth_deg: 0}")));
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.out.find("camera stereo_right: aravis sr BayerRG8 1920x1200 @ 10 Hz, trigger software (group stereo) (lidar front sweep at 0"),
            std::string::npos) << ok.out;
  const std::pair<const char*, const char*> cases[] = {
      {"{group: stereo, lidar: front, azimuth_deg: 10}", "17 cameras[1].trigger.azimuth_deg"},
      {"{group: stereo, lidar: rear, azimuth_deg: 0}", "17 cameras[1].trigger.lidar"},
      {"{group: stereo, lidar: front, azimuth_deg: 0, latency_us: 100}", "17 cameras[1].trigger.latency_us"},
      {"{mode: software, group: stereo}", "17 cameras[1].trigger.group"},
  };
  for (const auto& [trigger, where] : cases) {
    SCOPED_TRACE(trigger);
    const std::string file = write("group_bad.yaml", right(trigger));
    const auto r = run_rig("config check " + file);
    EXPECT_EQ(r.code, 2) << r.err;
    const auto errors = located(r.err, file);
    ASSERT_EQ(errors.size(), 1u) << r.err;
    EXPECT_EQ(errors[0], where) << r.err;
    EXPECT_NE(r.err.find("trigger group 'stereo': one trigger fires all its members, and camera 'stereo_left' is triggered by lidar front at azimuth_deg 0"),
              std::string::npos) << r.err;
  }
}

}  // namespace
// The summary `rig config check` prints names what the rig will run secured.
TEST_F(ConfigCheck, SummaryNamesTheSecuredCommandTopic) {
  const auto init = run_rig("security init " + (dir_ / "sec").string());
  ASSERT_EQ(init.code, 0) << init.err;
  const auto r = run_rig("config check " + write("sec.yaml", "rig:\n  name: s\ndbw:\n  mock_ecu: true\n  security: {dir: " +
                                                                (dir_ / "sec").string() + "}\n"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("[DDS Security on /vehicle/dbw/cmd: " + (dir_ / "sec").string() +
                       ", bridge 'dbw_bridge', command 'dbw_command']"),
            std::string::npos)
      << r.out;
}

}  // namespace sensor_rig::test
