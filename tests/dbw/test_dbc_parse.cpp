// DBC parser: the shared real-world DBCs parse completely; every statement kind; errors with lines.
#include <gtest/gtest.h>

#include <filesystem>
#include <limits>
#include <sstream>
#include <string>

#include "dbw_test_data.hpp"
#include "sensor_rig/dbw/dbc/codec.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace dbc = sensor_rig::dbw::dbc;
namespace fs = std::filesystem;
using sensor_rig::dbw::test::data_dir;
using sensor_rig::dbw::test::read_text;

namespace {

// Independent count: lines starting with "BO_ " and lines whose first token is "SG_".
std::pair<std::size_t, std::size_t> naive_counts(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::size_t bo = 0;
  std::size_t sg = 0;
  while (std::getline(in, line)) {
    if (line.rfind("BO_ ", 0) == 0) ++bo;
    const auto p = line.find_first_not_of(" \t");
    if (p != std::string::npos && line.compare(p, 4, "SG_ ") == 0) ++sg;
  }
  return {bo, sg};
}

TEST(DbcShared, EveryDbcParsesCompletely) {
  const fs::path dir = data_dir() / "can";
  if (!fs::exists(dir)) GTEST_SKIP() << "shared CAN data not found at " << dir << " (set RIG_TEST_DATA)";
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.path().extension() != ".dbc") continue;
    ++files;
    SCOPED_TRACE(e.path().string());
    const std::string text = read_text(e.path());
    dbc::Database db;
    ASSERT_NO_THROW(db = dbc::parse(text, e.path().string()));
    const auto [bo, sg] = naive_counts(text);
    EXPECT_EQ(db.messages.size(), bo);
    EXPECT_EQ(db.signal_count(), sg);
    for (const auto& m : db.messages) {
      for (const auto& s : m.signals) EXPECT_TRUE(dbc::signal_fits(s, m.size)) << m.name << "." << s.name;
    }
  }
  EXPECT_GE(files, 6U);
}

TEST(DbcShared, KnownContentOfRealFiles) {
  const fs::path dir = data_dir() / "can";
  if (!fs::exists(dir / "neweagle/New_Eagle_DBW_3.4.dbc")) GTEST_SKIP() << "shared CAN data not found at " << dir;
  const auto toyota = dbc::load_file((dir / "opendbc/_toyota_2017.dbc").string());
  EXPECT_EQ(toyota.messages.size(), 50U);
  EXPECT_EQ(toyota.signal_count(), 310U);
  EXPECT_EQ(toyota.nodes.size(), 7U);
  const auto* wheels = toyota.find(0xAA, false);
  ASSERT_NE(wheels, nullptr);
  EXPECT_EQ(wheels->name, "WHEEL_SPEEDS");
  const auto* fr = wheels->find("WHEEL_SPEED_FR");
  ASSERT_NE(fr, nullptr);
  EXPECT_EQ(fr->order, dbc::ByteOrder::kMotorola);
  EXPECT_EQ(fr->start_bit, 6);
  EXPECT_EQ(fr->length, 15);
  EXPECT_DOUBLE_EQ(fr->offset, -67.67);
  EXPECT_EQ(fr->unit, "km/h");
  EXPECT_EQ(fr->receivers.size(), 7U);
  EXPECT_EQ(fr->decimals, 2);

  const auto ne = dbc::load_file((dir / "neweagle/New_Eagle_DBW_3.4.dbc").string());
  EXPECT_EQ(ne.messages.size(), 36U);
  const auto* misc = ne.find("DBW_Misc");
  ASSERT_NE(misc, nullptr);
  EXPECT_TRUE(misc->extended);
  EXPECT_EQ(misc->id, 2147491585U & 0x1FFFFFFFU);
  EXPECT_NE(misc->find("DBW_MiscByWireEnabled")->comment.find("debugging purposes"), std::string::npos);
  EXPECT_EQ(misc->find("DBW_MiscByWireReady")->value_names.at(1), "Ready");
  // Multiplexed request: AKit_AccelReqType selects pedal / torque / speed signals.
  const dbc::Message* accel = nullptr;
  for (const auto& m : ne.messages) {
    if (m.find("AKit_AccelReqType") != nullptr) accel = &m;
  }
  ASSERT_NE(accel, nullptr);
  ASSERT_NE(accel->multiplexor(), nullptr);
  EXPECT_EQ(accel->multiplexor()->name, "AKit_AccelReqType");
  EXPECT_EQ(accel->find("AKit_SpeedReq")->mux, dbc::MuxRole::kMultiplexed);
  EXPECT_EQ(accel->find("AKit_SpeedReq")->mux_value, 2U);
}

constexpr const char* kSample = R"(VERSION "1.2"

NS_ :
	NS_DESC_
	CM_
	BA_DEF_

BS_:

BU_: ECU GW

VAL_TABLE_ OnOff 1 "On" 0 "Off" ;

BO_ 256 CMD: 8 GW
 SG_ Steer : 7|16@0- (0.001,0) [-10|10] "rad" ECU
 SG_ Mode M : 16|2@1+ (1,0) [0|3] "" ECU
 SG_ A m0 : 24|8@1+ (0.5,-10) [-10|117.5] "x" ECU,GW
 SG_ B m1 : 24|16@1- (1,0) [0|0] "" ECU
 SG_ F : 32|32@1- (1,0) [0|0] "" ECU

BO_ 2566914049 EXT: 64 ECU
 SG_ D : 0|64@1- (1,0) [0|0] "" GW

BO_TX_BU_ 256 : GW,ECU;

CM_ "network comment";
CM_ BU_ ECU "the ECU";
CM_ BO_ 256 "command
spanning lines";
CM_ SG_ 256 Steer "angle \"req\"";
BA_DEF_ BO_ "GenMsgCycleTime" INT 0 65535;
BA_DEF_ SG_ "GenSigStartValue" FLOAT -1e9 1e9;
BA_DEF_ "BusType" STRING ;
BA_DEF_ BO_ "VFrameFormat" ENUM "StandardCAN","ExtendedCAN","CAN FD";
BA_DEF_DEF_ "GenMsgCycleTime" 100;
BA_DEF_DEF_ "BusType" "CAN";
BA_DEF_DEF_ "VFrameFormat" "StandardCAN";
BA_DEF_DEF_ "GenSigStartValue" 0;
BA_ "BusType" "CAN FD";
BA_ "GenMsgCycleTime" BO_ 256 10;
BA_ "GenSigStartValue" SG_ 256 Steer 1.5;
VAL_ 256 Mode 0 "A" 1 "B" 2 "none" ;
SIG_VALTYPE_ 256 F : 1;
SIG_VALTYPE_ 2566914049 D : 2;
)";

TEST(DbcParse, EveryStatementKind) {
  const auto db = dbc::parse(kSample, "sample.dbc");
  EXPECT_EQ(db.version, "1.2");
  ASSERT_EQ(db.nodes.size(), 2U);
  EXPECT_EQ(db.value_tables.at("OnOff").at(1), "On");
  ASSERT_EQ(db.messages.size(), 2U);
  const auto& cmd = db.messages[0];
  EXPECT_EQ(cmd.id, 256U);
  EXPECT_FALSE(cmd.extended);
  EXPECT_EQ(cmd.comment, "command\nspanning lines");
  EXPECT_EQ(cmd.transmitters.size(), 2U);
  EXPECT_EQ(cmd.find("Steer")->comment, "angle \"req\"");
  EXPECT_TRUE(cmd.find("Steer")->is_signed);
  EXPECT_EQ(cmd.find("Steer")->decimals, 3);
  EXPECT_EQ(cmd.find("A")->receivers.size(), 2U);
  EXPECT_EQ(cmd.find("Mode")->value_names.at(2), "none");
  EXPECT_EQ(cmd.find("F")->value_type, dbc::ValueType::kFloat32);
  EXPECT_EQ(db.cycle_time_ms(cmd), 10);
  const auto& ext = db.messages[1];
  EXPECT_TRUE(ext.extended);
  EXPECT_EQ(ext.id, 2566914049U - 0x80000000U);
  EXPECT_EQ(ext.size, 64);
  EXPECT_EQ(ext.find("D")->value_type, dbc::ValueType::kFloat64);
  EXPECT_EQ(db.cycle_time_ms(ext), 100);  // BA_DEF_DEF_ default
  EXPECT_EQ(std::get<std::string>(db.attributes.at("BusType")), "CAN FD");
  EXPECT_DOUBLE_EQ(*dbc::attribute_number(*db.attribute(*cmd.find("Steer"), "GenSigStartValue")), 1.5);
  EXPECT_EQ(db.attribute_definitions.at("VFrameFormat").enum_values.size(), 3U);
  EXPECT_EQ(db.node_comments.at("ECU"), "the ECU");
  EXPECT_EQ(db.comment, "network comment");
}

// Each malformed input names the line of the problem.
struct BadCase {
  const char* text;
  int line;
  const char* needle;
};

TEST(DbcParse, ErrorsNameTheLine) {
  const BadCase cases[] = {
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@2+ (1,0) [0|0] \"\" X\n", 2, "byte order"},
      {"BO_ 1 M: 8 X\n SG_ S : 60|8@1+ (1,0) [0|0] \"\" X\n", 2, "does not fit"},
      {"BO_ 1 M: 8 X\n\n SG_ S : 0|0@1+ (1,0) [0|0] \"\" X\n", 3, "length"},
      {"BO_ 1 M: 65 X\n", 1, "64 bytes"},
      {"BO_ 1 M: 8 X\nBO_ 1 N: 8 X\n", 2, "duplicate message"},
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n SG_ S : 8|8@1+ (1,0) [0|0] \"\" X\n", 3, "duplicate signal"},
      {"FOO_ 1\n", 1, "unknown keyword"},
      {"\n\nCM_ BO_ 5 \"x\";\n", 3, "unknown message"},
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nCM_ SG_ 1 T \"x\";\n", 3, "unknown signal"},
      {"CM_ \"never closed;\n\n", 1, "unterminated"},
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1 0) [0|0] \"\" X\n", 2, "expected ','"},
      {"BA_ \"Nope\" 3;\n", 1, "undefined attribute"},
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nSIG_VALTYPE_ 1 S : 1;\n", 3, "32 bits"},
      {"BO_ 1 M: 8 X\n SG_ S m1 : 0|8@1+ (1,0) [0|0] \"\" X\n", 1, "no multiplexor"},
      {" SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n", 1, "before any BO_"},
      {"BO_ 1 M: 8 X\n SG_ S : 0|8@1+ (0,0) [0|0] \"\" X\n", 2, "factor 0"},
      {"BO_ 4294967296 M: 8 X\n", 1, "out of range"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      (void)dbc::parse(c.text, "bad.dbc");
      ADD_FAILURE() << "no error";
    } catch (const dbc::DbcError& e) {
      EXPECT_EQ(e.line, c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("bad.dbc:" + std::to_string(c.line) + ": ", 0), 0U) << e.what();
    }
  }
}

TEST(DbcParse, DecimalsOf) {
  EXPECT_EQ(dbc::decimals_of("1"), 0);
  EXPECT_EQ(dbc::decimals_of("0.01"), 2);
  EXPECT_EQ(dbc::decimals_of("-67.67"), 2);
  EXPECT_EQ(dbc::decimals_of("0.500"), 1);
  EXPECT_EQ(dbc::decimals_of("1E-005"), 5);
  EXPECT_EQ(dbc::decimals_of("2.5e-2"), 3);
  EXPECT_EQ(dbc::decimals_of("1e3"), 0);
  // A 10-digit exponent (fuzz_dbc's find) saturates instead of overflowing int (UBSan in CI).
  EXPECT_EQ(dbc::decimals_of("1e4000000000"), 0);
  EXPECT_GE(dbc::decimals_of("1e-4000000000"), 100'000);
}

// fuzz_dbc's finds: numbers beyond int64 where an integer is expected saturate (casting such a
// double is undefined behaviour: UBSan stops the sanitizer build there) instead of wrapping.
TEST(DbcParse, HugeIntegersSaturate) {
  std::string text(kSample);
  const std::string table = "VAL_TABLE_ OnOff 1 \"On\" 0 \"Off\" ;";
  ASSERT_NE(text.find(table), std::string::npos);
  text.replace(text.find(table), table.size(), "VAL_TABLE_ OnOff 1e23 \"On\" -3e114 \"Off\" ;");
  const auto db = dbc::parse(text, "huge.dbc");
  EXPECT_EQ(db.value_tables.at("OnOff").at(std::numeric_limits<std::int64_t>::max()), "On");
  EXPECT_EQ(db.value_tables.at("OnOff").at(std::numeric_limits<std::int64_t>::min()), "Off");
}

TEST(DbcParse, LoadFilesRejectsClashingIds) {
  const fs::path dir = fs::temp_directory_path() / ("dbc_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    std::ofstream(dir / "a.dbc") << "BO_ 1 A: 8 X\n";
    std::ofstream(dir / "b.dbc") << "BO_ 2 B: 8 X\n";
    std::ofstream(dir / "c.dbc") << "\nBO_ 1 C: 8 X\n";
  }
  const auto ab = dbc::load_files({(dir / "a.dbc").string(), (dir / "b.dbc").string()});
  EXPECT_EQ(ab.messages.size(), 2U);
  try {
    (void)dbc::load_files({(dir / "a.dbc").string(), (dir / "c.dbc").string()});
    ADD_FAILURE() << "no error";
  } catch (const dbc::DbcError& e) {
    EXPECT_EQ(e.line, 2);
  }
  EXPECT_THROW((void)dbc::load_file((dir / "missing.dbc").string()), dbc::DbcError);
  fs::remove_all(dir);
}

}  // namespace
