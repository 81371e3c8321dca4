// The dbw commands as processes: exit codes on bad input (SPEC §7: 2 = usage/config), the mock's
// bus log in $RIG_LOG_DIR, `rig can decode` on a small log with multiplexing, and `rig can replay`
// onto a unix seqpacket bus the test owns.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dbw_test_data.hpp"
#include "rig_cli.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace fs = std::filesystem;

namespace {

class DbwCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* b = std::getenv("RIG_BIN");
    if (b == nullptr || !fs::exists(b)) GTEST_SKIP() << "RIG_BIN not set or rig not built";
    bin_ = b;
    dir_ = fs::temp_directory_path() / ("dbw_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  int run(const std::string& args) {
    const int st = std::system((bin_ + " " + args + " >" + (dir_ / "out.txt").string() + " 2>&1").c_str());
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  }
  std::string bin_;
  fs::path dir_;
};

TEST_F(DbwCli, DecodeWritesRowsAndHonoursMultiplexing) {
  std::ofstream(dir_ / "m.dbc") << "BO_ 291 M: 8 X\n SG_ Sel M : 0|8@1+ (1,0) [0|0] \"\" X\n"
                                  " SG_ A m1 : 8|8@1+ (0.5,0) [0|0] \"\" X\n SG_ B m2 : 8|16@1- (1,0) [0|0] \"\" X\n"
                                  "BO_ 2147483905 E: 2 X\n SG_ V : 7|16@0+ (1,0) [0|0] \"\" X\n";
  std::ofstream(dir_ / "in.log") << "(1.000100) can0 123#0104\n(1.000200) can1 123#02FFFF\n(1.5) can0 00000101#0102\n"
                                   "(1.6) can0 7FF#00\nbroken line\n";
  ASSERT_EQ(run("can decode " + (dir_ / "in.log").string() + " --dbc " + (dir_ / "m.dbc").string() + " --csv " +
                (dir_ / "o.csv").string()),
            0);
  EXPECT_EQ(sensor_rig::dbw::test::read_text(dir_ / "o.csv"),
            "t,iface,id,message,signal,value\n"
            "1.000100,can0,123,M,Sel,1\n1.000100,can0,123,M,A,2.0\n"
            "1.000200,can1,123,M,Sel,2\n1.000200,can1,123,M,B,-1\n"
            "1.5,can0,00000101,E,V,258\n");
  EXPECT_NE(sensor_rig::dbw::test::read_text(dir_ / "out.txt").find("1 malformed"), std::string::npos);
  ASSERT_EQ(run("can decode " + (dir_ / "in.log").string() + " --dbc " + (dir_ / "m.dbc").string() +
                " --signals M.A --csv " + (dir_ / "a.csv").string()),
            0);
  EXPECT_EQ(sensor_rig::dbw::test::read_text(dir_ / "a.csv"), "t,iface,id,message,signal,value\n1.000100,can0,123,M,A,2.0\n");
}

TEST_F(DbwCli, BadInputExitsWithUsageCode) {
  std::ofstream(dir_ / "bad.dbc") << "BO_ 1 M: 8 X\n SG_ S : 0|8@7+ (1,0) [0|0] \"\" X\n";
  std::ofstream(dir_ / "in.log") << "(1.0) can0 001#00\n";
  EXPECT_EQ(run("can decode " + (dir_ / "in.log").string() + " --dbc " + (dir_ / "bad.dbc").string() + " --csv " +
                (dir_ / "o.csv").string()),
            2);
  EXPECT_NE(sensor_rig::dbw::test::read_text(dir_ / "out.txt").find("bad.dbc:2:"), std::string::npos);
  std::ofstream(dir_ / "ok.dbc") << "BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n";
  EXPECT_EQ(run("can decode " + (dir_ / "in.log").string() + " --dbc " + (dir_ / "ok.dbc").string() +
                " --signals M.NOPE --csv " + (dir_ / "o.csv").string()),
            2);
  EXPECT_EQ(run("can decode /nonexistent.log --dbc " + (dir_ / "ok.dbc").string() + " --csv " + (dir_ / "o.csv").string()), 2);
  EXPECT_EQ(run("mock paravan --fault melt --duration 0.1"), 2);
  EXPECT_EQ(run("mock paravan --config " + (dir_ / "ok.dbc").string() + " --duration 0.1"), 2);
  EXPECT_EQ(run("dbw send --rate 0 --duration 1"), 2);
}

TEST_F(DbwCli, MockLogsToRigLogDir) {
  const std::string sock = (dir_ / "bus.sock").string();
  const int st = std::system(("RIG_LOG_DIR=" + dir_.string() + " " + bin_ + " mock paravan --transport unix-listen:" + sock +
                              " --duration 0.3 >/dev/null 2>&1")
                                 .c_str());
  ASSERT_EQ(WEXITSTATUS(st), 0);
  const std::string log = sensor_rig::dbw::test::read_text(dir_ / "dbw_bus.log");
  EXPECT_GT(std::count(log.begin(), log.end(), '\n'), 40);
  EXPECT_NE(log.find(" can0 180#"), std::string::npos);
}

// A generated log with classic, extended, remote and FD frames, a 10 ms cadence and a 200 ms gap,
// replayed at twice the recorded speed: every frame arrives unchanged, in order, at its scaled time.
TEST_F(DbwCli, ReplaySendsTheLogAtItsScaledTiming) {
  namespace can = sensor_rig::dbw::can;
  std::ostringstream text;
  std::vector<can::LogRecord> expected;
  const char* frames[] = {"123#0102030405060708", "1ABCDEF0#CAFE", "7FF#R", "456##1000102030405060708090A0B", "010#"};
  double t = 1700000000.0;
  for (int i = 0; i < 30; ++i) {
    t += i == 20 ? 0.2 : 0.01;
    char line[160];
    std::snprintf(line, sizeof line, "(%.6f) can%d %s", t, i % 2, frames[i % 5]);
    text << line << "\n";
    can::LogRecord r;
    ASSERT_EQ(can::parse_candump_line(line, r), can::LineStatus::kOk) << line;
    expected.push_back(r);
  }
  std::ofstream(dir_ / "gen.log") << text.str();
  const std::string sock = (dir_ / "replay.sock").string();
  auto bus = can::open_transport("unix-listen:" + sock);
  sensor_rig::test::CliRun replay;
  std::thread runner([&] { replay = sensor_rig::test::run_rig("can replay " + (dir_ / "gen.log").string() +
                                                              " --transport unix:" + sock + " --rate 2"); });
  std::vector<can::RxFrame> got;
  can::RxFrame rx;
  while (got.size() < expected.size() && bus->receive(rx, 3000) == can::IoStatus::kOk) got.push_back(rx);
  runner.join();
  EXPECT_EQ(replay.code, 0) << replay.err;
  EXPECT_NE(replay.err.find(std::to_string(expected.size()) + " frames sent, 0 refused"), std::string::npos) << replay.err;
  ASSERT_EQ(got.size(), expected.size());
  // Never early (the schedule is the log's, scaled); late only where the shared host descheduled a
  // process: the median frame is on time, which a replay at rate 1 (median ~120 ms late) is not.
  std::vector<double> late_ms;
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_TRUE(got[i].frame == expected[i].frame) << i << ": " << can::format_frame(got[i].frame) << " vs "
                                                   << can::format_frame(expected[i].frame);
    const double want_ms = static_cast<double>(expected[i].stamp - expected[0].stamp) * 1e-6 / 2.0;
    const double got_ms = static_cast<double>(got[i].stamp - got[0].stamp) * 1e-6;
    EXPECT_GE(got_ms, want_ms - 2.0) << "frame " << i << " early";
    late_ms.push_back(got_ms - want_ms);
  }
  std::sort(late_ms.begin(), late_ms.end());
  EXPECT_LT(late_ms[late_ms.size() / 2], 30.0) << "median lateness; worst " << late_ms.back() << " ms";
  const double span_ms = static_cast<double>(got.back().stamp - got.front().stamp) * 1e-6;
  EXPECT_GT(span_ms, 230.0) << "rate 2 of a 0.48 s log";
}

}  // namespace
