// The dbw commands as processes: exit codes on bad input (SPEC §7: 2 = usage/config), the mock's
// bus log in $RIG_LOG_DIR, and `rig can decode` on a small log with multiplexing.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "dbw_test_data.hpp"

namespace fs = std::filesystem;

namespace {

class DbwCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* b = std::getenv("RIG_BIN");
    if (b == nullptr || !fs::exists(b)) GTEST_SKIP() << "RIG_BIN not set or rig not built";
    bin = b;
    dir = fs::temp_directory_path() / ("dbw_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir);
  }
  void TearDown() override {
    if (!dir.empty()) fs::remove_all(dir);
  }
  int run(const std::string& args) {
    const int st = std::system((bin + " " + args + " >" + (dir / "out.txt").string() + " 2>&1").c_str());
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  }
  std::string bin;
  fs::path dir;
};

TEST_F(DbwCli, DecodeWritesRowsAndHonoursMultiplexing) {
  std::ofstream(dir / "m.dbc") << "BO_ 291 M: 8 X\n SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ A m1 : 8|8@1+ (0.5,0) [0|0] \"\" X\n SG_ B m2 : 8|16@1- (1,0) [0|0] \"\" X\n"
                                  "BO_ 2147483905 E: 2 X\n SG_ V : 7|16@0+ (1,0) [0|0] \"\" X\n";
  std::ofstream(dir / "in.log") << "(1.000100) can0 123#0104\n(1.000200) can1 123#02FFFF\n(1.5) can0 00000101#0102\n"
                                   "(1.6) can0 7FF#00\nbroken line\n";
  ASSERT_EQ(run("can decode " + (dir / "in.log").string() + " --dbc " + (dir / "m.dbc").string() + " --csv " +
                (dir / "o.csv").string()),
            0);
  EXPECT_EQ(sensor_rig::dbw::test::read_text(dir / "o.csv"),
            "t,iface,id,message,signal,value\n"
            "1.000100,can0,123,M,Sel,1\n1.000100,can0,123,M,A,2.0\n"
            "1.000200,can1,123,M,Sel,2\n1.000200,can1,123,M,B,-1\n"
            "1.5,can0,00000101,E,V,258\n");
  EXPECT_NE(sensor_rig::dbw::test::read_text(dir / "out.txt").find("1 malformed"), std::string::npos);
  ASSERT_EQ(run("can decode " + (dir / "in.log").string() + " --dbc " + (dir / "m.dbc").string() +
                " --signals M.A --csv " + (dir / "a.csv").string()),
            0);
  EXPECT_EQ(sensor_rig::dbw::test::read_text(dir / "a.csv"), "t,iface,id,message,signal,value\n1.000100,can0,123,M,A,2.0\n");
}

TEST_F(DbwCli, BadInputExitsWithUsageCode) {
  std::ofstream(dir / "bad.dbc") << "BO_ 1 M: 8 X\n SG_ S : 0|8@7+ (1,0) [0|0] \"\" X\n";
  std::ofstream(dir / "in.log") << "(1.0) can0 001#00\n";
  EXPECT_EQ(run("can decode " + (dir / "in.log").string() + " --dbc " + (dir / "bad.dbc").string() + " --csv " +
                (dir / "o.csv").string()),
            2);
  EXPECT_NE(sensor_rig::dbw::test::read_text(dir / "out.txt").find("bad.dbc:2:"), std::string::npos);
  std::ofstream(dir / "ok.dbc") << "BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n";
  EXPECT_EQ(run("can decode " + (dir / "in.log").string() + " --dbc " + (dir / "ok.dbc").string() +
                " --signals M.NOPE --csv " + (dir / "o.csv").string()),
            2);
  EXPECT_EQ(run("can decode /nonexistent.log --dbc " + (dir / "ok.dbc").string() + " --csv " + (dir / "o.csv").string()), 2);
  EXPECT_EQ(run("mock paravan --fault melt --duration 0.1"), 2);
  EXPECT_EQ(run("mock paravan --config " + (dir / "ok.dbc").string() + " --duration 0.1"), 2);
  EXPECT_EQ(run("dbw send --rate 0 --duration 1"), 2);
}

TEST_F(DbwCli, MockLogsToRigLogDir) {
  const std::string sock = (dir / "bus.sock").string();
  const int st = std::system(("RIG_LOG_DIR=" + dir.string() + " " + bin + " mock paravan --transport unix-listen:" + sock +
                              " --duration 0.3 >/dev/null 2>&1")
                                 .c_str());
  ASSERT_EQ(WEXITSTATUS(st), 0);
  const std::string log = sensor_rig::dbw::test::read_text(dir / "dbw_bus.log");
  EXPECT_GT(std::count(log.begin(), log.end(), '\n'), 40);
  EXPECT_NE(log.find(" can0 180#"), std::string::npos);
}

}  // namespace
