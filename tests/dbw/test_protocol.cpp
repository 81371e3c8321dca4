// The reference protocol loads, maps every role, and bad mappings give file:line errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "dbw_test_data.hpp"
#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"

namespace fs = std::filesystem;
using sensor_rig::dbw::Protocol;

namespace {

fs::path ref_yaml() { return sensor_rig::dbw::test::source_dir() / "config/dbw/paravan_ref.yaml"; }

TEST(Protocol, ReferenceLoadsWithE2eLayout) {
  const auto p = Protocol::load(ref_yaml().string());
  EXPECT_EQ(p.config_hash().size(), 16U);
  EXPECT_EQ(p.limits().name, "paravan_ref");
  EXPECT_EQ(p.timing().command_timeout_ns, 100'000'000);
  const auto* st = p.tx("steering");
  ASSERT_NE(st, nullptr);
  EXPECT_EQ(st->message->id, 0x100U);
  EXPECT_EQ(st->e2e.profile, sensor_rig::dbw::safety::E2eProfile::kP01);
  EXPECT_EQ(st->e2e.crc_byte, 0U);
  EXPECT_EQ(st->e2e.counter_byte, 1U);
  EXPECT_FALSE(st->e2e.counter_high_nibble);
  EXPECT_EQ(st->e2e.data_id, 0x100);
  EXPECT_NE(p.rx("status"), nullptr);
  EXPECT_EQ(p.rx("wheels")->e2e.profile, sensor_rig::dbw::safety::E2eProfile::kNone);
  EXPECT_EQ(p.db().cycle_time_ms(*st->message), 10);

  sensor_rig::dbw::safety::E2eSender tx(st->e2e);
  sensor_rig::dbw::can::Frame f;
  ASSERT_TRUE(p.encode(*st, {{"enable", 1}, {"angle", -0.25}}, &tx, f));
  EXPECT_EQ(f.len, 8);
  EXPECT_DOUBLE_EQ(*Protocol::value(*st, "angle", f), -0.25);
  EXPECT_DOUBLE_EQ(*Protocol::value(*st, "enable", f), 1.0);
  sensor_rig::dbw::safety::E2eChecker rx(st->e2e);
  EXPECT_EQ(rx.check(f.payload()), sensor_rig::dbw::safety::E2eStatus::kOk);
  EXPECT_FALSE(p.encode(*st, {{"angle", std::nan("")}}, &tx, f));
}

TEST(Protocol, HashChangesWithTheMapping) {
  const fs::path dir = fs::temp_directory_path() / ("proto_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(ref_yaml().parent_path() / "paravan_ref.dbc", dir / "paravan_ref.dbc");
  std::string text = sensor_rig::dbw::test::read_text(ref_yaml());
  std::ofstream(dir / "a.yaml") << text;
  const auto a = Protocol::load((dir / "a.yaml").string());
  EXPECT_EQ(a.config_hash(), Protocol::load(ref_yaml().string()).config_hash());
  std::ofstream(dir / "b.yaml") << text << "\n# changed\n";
  EXPECT_NE(Protocol::load((dir / "b.yaml").string()).config_hash(), a.config_hash());
  fs::remove_all(dir);
}

TEST(Protocol, HashChangesWithTheDbcAlone) {
  const fs::path dir = fs::temp_directory_path() / ("protodbc_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string dbc = sensor_rig::dbw::test::read_text(ref_yaml().parent_path() / "paravan_ref.dbc");
  const std::string yaml = sensor_rig::dbw::test::read_text(ref_yaml());
  std::ofstream(dir / "paravan_ref.dbc") << dbc;
  std::ofstream(dir / "m.yaml") << yaml;
  const std::string base = Protocol::load((dir / "m.yaml").string()).config_hash();
  EXPECT_EQ(base, Protocol::load(ref_yaml().string()).config_hash()) << "same bytes, other directory: same hash";
  // The mapping file stays byte for byte the same; only the DBC it names changes (a cycle time).
  std::string changed = dbc;
  const std::string from = "BA_ \"GenMsgCycleTime\" BO_ 384 10;";
  const auto pos = changed.find(from);
  ASSERT_NE(pos, std::string::npos);
  changed.replace(pos, from.size(), "BA_ \"GenMsgCycleTime\" BO_ 384 20;");
  std::ofstream(dir / "paravan_ref.dbc", std::ios::trunc) << changed;
  const auto p = Protocol::load((dir / "m.yaml").string());
  EXPECT_EQ(p.db().cycle_time_ms(*p.rx("status")->message), 20) << "the changed DBC was loaded";
  EXPECT_NE(p.config_hash(), base);
  EXPECT_EQ(p.config_hash().size(), 16U);
  fs::remove_all(dir);
}

TEST(Protocol, LimitOverridesFromTheMapping) {
  const fs::path dir = fs::temp_directory_path() / ("protolim_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(ref_yaml().parent_path() / "paravan_ref.dbc", dir / "paravan_ref.dbc");
  std::ofstream(dir / "l.yaml") << sensor_rig::dbw::test::read_text(ref_yaml())
                                << "limits:\n  steering_angle: {max: 0.3, rate: 0.2, action: reject}\n";
  const auto p = Protocol::load((dir / "l.yaml").string());
  const auto& a = p.limits()[sensor_rig::dbw::safety::Axis::kSteeringAngle];
  EXPECT_DOUBLE_EQ(a.max, 0.3);
  EXPECT_DOUBLE_EQ(a.min, -0.6);  // untouched keys keep the table's value
  EXPECT_DOUBLE_EQ(a.max_rate, 0.2);
  EXPECT_EQ(a.action, sensor_rig::dbw::safety::LimitAction::kReject);
  std::ofstream(dir / "bad.yaml") << sensor_rig::dbw::test::read_text(ref_yaml()) << "limits:\n  throttle: {min: 1, max: 0.5}\n";
  EXPECT_THROW((void)Protocol::load((dir / "bad.yaml").string()), sensor_rig::ConfigError);
  fs::remove_all(dir);
}

TEST(Protocol, BadMappingsNameFileAndLine) {
  const fs::path dir = fs::temp_directory_path() / ("protobad_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(ref_yaml().parent_path() / "paravan_ref.dbc", dir / "paravan_ref.dbc");
  const std::string good = sensor_rig::dbw::test::read_text(ref_yaml());
  struct Case {
    std::string from, to, needle;
  };
  const Case cases[] = {
      {"message: PRV_CMD_STEER", "message: NOPE", "no message 'NOPE'"},
      {"angle: STEER_ANGLE_REQ", "angle: NOPE", "no signal 'NOPE'"},
      {"counter: COUNTER\n    crc: CRC\n    signals: {enable: STEER_ENABLE", "counter: STEER_MODE\n    crc: CRC\n    signals: {enable: STEER_ENABLE", "4-bit"},
      {"vehicle: paravan_ref", "vehicle: tractor", "unknown vehicle"},
      {"profile: p01", "profile: p07", "profile"},
      {"dbc: paravan_ref.dbc", "dbc: missing.dbc", "cannot open"},
      {"tx_period_ms: 10", "tx_period_ms: 200", "shorter than"},
      {"signals: {enable: STEER_ENABLE, mode: STEER_MODE, angle: STEER_ANGLE_REQ, torque: STEER_TORQUE_REQ}",
       "signals: {mode: STEER_MODE, angle: STEER_ANGLE_REQ}", "required role 'enable'"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.to);
    std::string text = good;
    const auto pos = text.find(c.from);
    ASSERT_NE(pos, std::string::npos);
    text.replace(pos, c.from.size(), c.to);
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n');
    std::ofstream(dir / "bad.yaml") << text;
    try {
      (void)Protocol::load((dir / "bad.yaml").string());
      ADD_FAILURE() << "no error";
    } catch (const sensor_rig::ConfigError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(c.needle), std::string::npos) << msg;
      EXPECT_NE(msg.find((dir / "bad.yaml").string() + ":"), std::string::npos) << msg;
      if (c.needle != "cannot open") {
        EXPECT_NE(msg.find(":" + std::to_string(line) + ":"), std::string::npos) << msg;
      }
    }
  }
  fs::remove_all(dir);
}

}  // namespace
