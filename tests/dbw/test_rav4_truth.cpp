// The shared comma2k19 RAV4 log decoded with the opendbc Toyota DBCs reproduces the truth CSVs
// exactly: speed (mean of the four wheel speeds) and wheel speeds in m/s with 9 decimals, steering
// angle (STEER_ANGLE + STEER_FRACTION) in degrees with 4 decimals. Once through the library, once
// through `rig can decode`.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "dbw_test_data.hpp"
#include "sensor_rig/dbw/can/log_decode.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace can = sensor_rig::dbw::can;
namespace dbc = sensor_rig::dbw::dbc;
namespace fs = std::filesystem;
using sensor_rig::dbw::test::data_dir;

namespace {

struct Paths {
  fs::path log, speed, steering;
  std::vector<std::string> dbcs;
};

std::optional<Paths> find_data() {
  const fs::path d = data_dir() / "can";
  Paths p{d / "comma2k19_rav4/rav4_seg40.candump.log", d / "comma2k19_rav4/rav4_seg40.truth_speed.csv",
          d / "comma2k19_rav4/rav4_seg40.truth_steering.csv",
          {(d / "opendbc/_toyota_2017.dbc").string(), (d / "opendbc/toyota_new_mc_pt.dbc").string()}};
  if (!fs::exists(p.log) || !fs::exists(p.speed) || !fs::exists(p.steering)) return std::nullopt;
  return p;
}

std::string fmt(int decimals, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Builds the truth CSV text from decoded rows (t, message, signal, value as text).
struct TruthBuilder {
  std::string speed = "t_boot_s,speed_mps,wheel_fl_mps,wheel_fr_mps,wheel_rl_mps,wheel_rr_mps\n";
  std::string steering = "t_boot_s,steering_angle_deg\n";
  std::string t;
  std::map<std::string, double> cur;

  void add(const std::string& stamp, const std::string& message, const std::string& signal, double value) {
    if (stamp != t) flush();
    t = stamp;
    cur[message + "." + signal] = value;
  }
  void flush() {
    if (cur.count("WHEEL_SPEEDS.WHEEL_SPEED_FL") != 0) {
      const double fl = cur["WHEEL_SPEEDS.WHEEL_SPEED_FL"], fr = cur["WHEEL_SPEEDS.WHEEL_SPEED_FR"];
      const double rl = cur["WHEEL_SPEEDS.WHEEL_SPEED_RL"], rr = cur["WHEEL_SPEEDS.WHEEL_SPEED_RR"];
      const double k = 1.0 / 3.6;
      speed += t + "," + fmt(9, (fl + fr + rl + rr) / 4.0 * k) + "," + fmt(9, fl * k) + "," +
               fmt(9, fr * k) + "," + fmt(9, rl * k) + "," + fmt(9, rr * k) + "\n";
    }
    if (cur.count("STEER_ANGLE_SENSOR.STEER_ANGLE") != 0) {
      steering += t + "," +
                  fmt(4, cur["STEER_ANGLE_SENSOR.STEER_ANGLE"] + cur["STEER_ANGLE_SENSOR.STEER_FRACTION"]) + "\n";
    }
    cur.clear();
  }
};

const std::vector<std::string> kSignals = {
    "WHEEL_SPEEDS.WHEEL_SPEED_FL", "WHEEL_SPEEDS.WHEEL_SPEED_FR",      "WHEEL_SPEEDS.WHEEL_SPEED_RL",
    "WHEEL_SPEEDS.WHEEL_SPEED_RR", "STEER_ANGLE_SENSOR.STEER_ANGLE", "STEER_ANGLE_SENSOR.STEER_FRACTION"};

void expect_same_text(const std::string& got, const fs::path& truth) {
  const std::string want = sensor_rig::dbw::test::read_text(truth);
  if (got == want) return;
  std::istringstream a(got), b(want);
  std::string la, lb;
  int line = 0;
  while (true) {
    ++line;
    const bool ha = static_cast<bool>(std::getline(a, la));
    const bool hb = static_cast<bool>(std::getline(b, lb));
    if (!ha && !hb) break;
    if (la != lb || ha != hb) {
      ADD_FAILURE() << truth << " line " << line << ": got '" << la << "' want '" << lb << "'";
      return;
    }
  }
  ADD_FAILURE() << truth << ": differs (line endings?)";
}

TEST(Rav4Truth, LibraryReproducesTruthCsvs) {
  const auto p = find_data();
  if (!p) GTEST_SKIP() << "RAV4 log/truth not found under " << data_dir() << " (set RIG_TEST_DATA)";
  const auto db = dbc::load_files(p->dbcs);
  const can::LogDecoder dec(db, kSignals);
  std::ifstream in(p->log);
  can::CandumpReader reader(in);
  can::LogRecord rec;
  can::DecodeStats st;
  TruthBuilder tb;
  const std::function<void(const can::LogDecoder::Row&)> sink = [&](const can::LogDecoder::Row& r) {
    if (r.record->iface == "can0") tb.add(r.record->stamp_text, r.message->name, r.signal->name, r.value);
  };
  while (reader.next(rec)) dec.decode(rec, sink, st);
  tb.flush();
  EXPECT_EQ(reader.malformed(), 0U);
  EXPECT_EQ(st.frames, 135468U);
  EXPECT_EQ(st.decoded, 2U * 4974U);
  expect_same_text(tb.speed, p->speed);
  expect_same_text(tb.steering, p->steering);
}

TEST(Rav4Truth, CliReproducesTruthCsvs) {
  const auto p = find_data();
  if (!p) GTEST_SKIP() << "RAV4 log/truth not found under " << data_dir() << " (set RIG_TEST_DATA)";
  const char* bin = std::getenv("RIG_BIN");
  if (bin == nullptr || !fs::exists(bin)) GTEST_SKIP() << "RIG_BIN not set or not built: the rig executable is needed";
  const fs::path out = fs::temp_directory_path() / ("rav4_decode_" + std::to_string(::getpid()) + ".csv");
  std::string cmd = std::string(bin) + " can decode " + p->log.string() + " --dbc";
  for (const auto& d : p->dbcs) cmd += " " + d;
  cmd += " --signals ";
  for (std::size_t i = 0; i < kSignals.size(); ++i) cmd += (i ? "," : "") + kSignals[i];
  cmd += " --csv " + out.string() + " 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream csv(out);
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "t,iface,id,message,signal,value");
  TruthBuilder tb;
  std::size_t rows = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string x;
    while (std::getline(ss, x, ',')) f.push_back(x);
    ASSERT_EQ(f.size(), 6U) << line;
    ++rows;
    if (f[1] == "can0") tb.add(f[0], f[3], f[4], std::stod(f[5]));
  }
  tb.flush();
  EXPECT_EQ(rows, 6U * 4974U);
  expect_same_text(tb.speed, p->speed);
  expect_same_text(tb.steering, p->steering);
  fs::remove(out);
}

}  // namespace
