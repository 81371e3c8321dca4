// Protocols other than the reference by configuration only. A small inline DBC: roles in separate
// messages, each with its own E2E profile (P01, counter only, P02 with its own DataIDList), constants
// and scales. Then the real New Eagle DBW 3.4 mapping (config/dbw/neweagle_dbw_3_4.yaml) with New
// Eagle's DBC (RIG_TEST_DATA/can/neweagle, not in the repository): the bridge's frames are decoded
// back with the DBC codec (independently of the mapping) and checked signal by signal.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "dbw_test_data.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/dbw/dbc/codec.hpp"

namespace fs = std::filesystem;
namespace dbw = sensor_rig::dbw;
namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;
using sensor_rig::kMs;

namespace {

constexpr double kDegPerRoadRad = 15.0 * 180.0 / 3.14159265358979323846;  // the mapping's ratio

constexpr const char* kSplitDbc =
    "BO_ 16 STEER: 8 PU\n SG_ CRC : 0|8@1+ (1,0) [0|255] \"\" ECU\n SG_ CNT : 8|4@1+ (1,0) [0|15] \"\" ECU\n"
    " SG_ EN : 12|1@1+ (1,0) [0|1] \"\" ECU\n SG_ ANG : 16|16@1- (0.001,0) [-32|32] \"rad\" ECU\n"
    "BO_ 17 GAS: 8 PU\n SG_ CNT : 8|4@1+ (1,0) [0|15] \"\" ECU\n SG_ EN : 12|1@1+ (1,0) [0|1] \"\" ECU\n"
    " SG_ PEDAL : 16|8@1+ (0.5,0) [0|100] \"%\" ECU\n SG_ TYPE : 24|2@1+ (1,0) [0|3] \"\" ECU\n"
    "BO_ 18 BRK: 8 PU\n SG_ CRC : 0|8@1+ (1,0) [0|255] \"\" ECU\n SG_ CNT : 8|4@1+ (1,0) [0|15] \"\" ECU\n"
    " SG_ EN : 12|1@1+ (1,0) [0|1] \"\" ECU\n SG_ PEDAL : 16|8@1+ (0.5,0) [0|100] \"%\" ECU\n"
    "BO_ 32 ECU: 8 ECU\n SG_ READY : 0|1@1+ (1,0) [0|1] \"\" PU\n SG_ OVR : 1|1@1+ (1,0) [0|1] \"\" PU\n"
    " SG_ FLT : 2|1@1+ (1,0) [0|1] \"\" PU\n SG_ SPD : 8|16@1+ (0.01,0) [0|600] \"m/s\" PU\n"
    " SG_ STEER : 24|16@1- (0.001,0) [-32|32] \"rad\" PU\n";

constexpr const char* kSplitMapping =
    "dbc: split.dbc\n"
    "e2e: {profile: p01, data_id_mode: both}\n"
    "tx:\n"
    "  steer: {message: STEER, data_id: 0x10, counter: CNT, crc: CRC, signals: {enable: EN, angle: ANG}}\n"
    "  gas: {message: GAS, counter: CNT, e2e: {profile: counter}, const: {TYPE: 2},\n"
    "        signals: {enable: EN, throttle: {signal: PEDAL, scale: 100}}}\n"
    "  brk: {message: BRK, counter: CNT, crc: CRC, e2e: {profile: p02},\n"
    "        data_id_list: [160, 161, 162, 163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175],\n"
    "        signals: {enable: EN, brake: {signal: PEDAL, scale: 100}}}\n"
    "rx:\n"
    "  ecu: {message: ECU, signals: {ready: READY, override: OVR, fault: FLT, speed: SPD, steering_angle: STEER}}\n";

class SplitProtocol : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("split_proto_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "split.dbc") << kSplitDbc;
  }
  void TearDown() override { fs::remove_all(dir_); }
  dbw::Protocol load(const std::string& yaml) {
    std::ofstream(dir_ / "m.yaml", std::ios::trunc) << yaml;
    return dbw::Protocol::load((dir_ / "m.yaml").string());
  }
  std::string error_of(const std::string& yaml) {
    try {
      (void)load(yaml);
    } catch (const sensor_rig::ConfigError& e) {
      return e.what();
    }
    return "no error";
  }
  fs::path dir_;
};

TEST_F(SplitProtocol, RolesInSeparateMessagesEachWithItsOwnE2e) {
  const auto p = load(kSplitMapping);
  EXPECT_EQ(p.tx("steer")->e2e.profile, s::E2eProfile::kP01);
  EXPECT_EQ(p.tx("gas")->e2e.profile, s::E2eProfile::kCounter);
  EXPECT_EQ(p.tx("brk")->e2e.profile, s::E2eProfile::kP02);
  EXPECT_EQ(p.tx("brk")->e2e.data_id_list[5], 165);
  dbw::BridgeCore bridge(p);
  Nanos now = 1'000'000'000'000;
  dbw::can::Frame status;
  ASSERT_TRUE(p.encode(*p.rx("ecu"), {{"ready", 1}}, nullptr, status));
  s::Command c;
  // 1 s of the same command after the enable edge: the rate limits (from the measured state on
  // engagement) have reached it.
  for (int i = 0; i < 101; ++i) {
    bridge.on_frame({status, now}, now);
    c.stamp = now;
    c.seq = static_cast<std::uint64_t>(i) + 1;
    c.enable = i >= 1;
    c.steering_angle = -0.25;
    c.throttle = 0.4;
    c.brake = 0.04;  // below the pedal interlock's cutoff: throttle stays
    bridge.on_command(c, now, now);
    now += 10 * kMs;
  }
  ASSERT_EQ(bridge.safety().state(), s::State::kEngaged);
  std::vector<dbw::can::Frame> frames;
  bridge.frames(now, frames);
  ASSERT_EQ(frames.size(), 3U);
  std::map<std::string, dbw::can::Frame> by_label;
  for (const auto& f : frames) {
    for (const auto& rm : p.tx_messages()) {
      if (rm.matches(f)) by_label[rm.role] = f;
    }
  }
  ASSERT_EQ(by_label.size(), 3U);
  auto sig = [&](const char* label, const char* name) {
    const auto& f = by_label[label];
    return *dbw::dbc::decode(*p.db().find(f.id, false)->find(name), f.payload());
  };
  EXPECT_EQ(sig("steer", "EN"), 1.0);
  EXPECT_NEAR(sig("steer", "ANG"), -0.25, 1e-9);
  EXPECT_EQ(sig("gas", "EN"), 1.0);
  EXPECT_NEAR(sig("gas", "PEDAL"), 40.0, 1e-9);  // 0.4 * 100 %
  EXPECT_EQ(sig("gas", "TYPE"), 2.0);
  EXPECT_EQ(sig("brk", "EN"), 1.0);
  EXPECT_NEAR(sig("brk", "PEDAL"), 4.0, 1e-9);
  // Each frame passes its own message's check; the P02 CRC uses the mapping's DataIDList.
  for (const auto& rm : p.tx_messages()) {
    s::E2eChecker chk(rm.e2e);
    EXPECT_EQ(chk.check(by_label[rm.role].payload()), s::E2eStatus::kOk) << rm.role;
  }
  s::E2eConfig default_list = p.tx("brk")->e2e;
  for (std::size_t i = 0; i < 16; ++i) default_list.data_id_list[i] = static_cast<std::uint8_t>(i);
  s::E2eChecker wrong(default_list);
  EXPECT_EQ(wrong.check(by_label["brk"].payload()), s::E2eStatus::kBadCrc);
  EXPECT_EQ(by_label["gas"].data[0], 0) << "counter-only message: no CRC written";
}

TEST_F(SplitProtocol, BadSplitMappingsAreExplained) {
  std::string m = kSplitMapping;
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = m;
    t.replace(t.find(from), from.size(), to);
    return error_of(t);
  };
  EXPECT_NE(with("signals: {enable: EN, throttle:", "signals: {throttle:").find("required role 'enable'"), std::string::npos);
  EXPECT_NE(with("throttle: {signal: PEDAL, scale: 100}", "accel: PEDAL").find("role 'throttle' is not mapped in any tx"),
            std::string::npos);
  EXPECT_NE(with("angle: ANG", "wiper: ANG").find("unknown role 'wiper'"), std::string::npos);
  EXPECT_NE(with("[160, 161, 162, 163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175]", "[160, 161]")
                .find("list of 16"),
            std::string::npos);
  EXPECT_NE(with("const: {TYPE: 2}", "const: {NOPE: 2}").find("no signal 'NOPE'"), std::string::npos);
}

class NewEagle : public ::testing::Test {
 protected:
  void SetUp() override {
    const fs::path dbc = dbw::test::data_dir() / "can/neweagle/New_Eagle_DBW_3.4.dbc";
    if (!fs::exists(dbc)) GTEST_SKIP() << "New Eagle DBC not found (" << dbc << "); set RIG_TEST_DATA";
    dir_ = fs::temp_directory_path() / ("neweagle_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    fs::copy_file(dbc, dir_ / "New_Eagle_DBW_3.4.dbc", fs::copy_options::overwrite_existing);
    fs::copy_file(dbw::test::source_dir() / "config/dbw/neweagle_dbw_3_4.yaml", dir_ / "m.yaml",
                  fs::copy_options::overwrite_existing);
    p_ = std::make_unique<dbw::Protocol>(dbw::Protocol::load((dir_ / "m.yaml").string()));
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  // Every signal of every frame, decoded with the DBC alone: "Message.Signal" -> value.
  std::map<std::string, double> decode_all(const std::vector<dbw::can::Frame>& frames) const {
    std::map<std::string, double> v;
    for (const auto& f : frames) {
      const auto* m = p_->db().find(f.id, f.extended);
      if (m == nullptr) {
        ADD_FAILURE() << "frame id " << f.id << " is not in the DBC";
        continue;
      }
      for (const auto& sig : m->signals) v[m->name + "." + sig.name] = dbw::dbc::decode(sig, f.payload()).value_or(-999);
    }
    return v;
  }
  void ecu_ready(dbw::BridgeCore& b, Nanos now) const {
    dbw::can::Frame f;
    ASSERT_TRUE(p_->encode(*p_->rx("misc"), {{"ready", 1}}, nullptr, f));
    b.on_frame({f, now}, now);
  }
  fs::path dir_;
  std::unique_ptr<dbw::Protocol> p_;
};

TEST_F(NewEagle, MappingLoadsWithRolesInSeparateMessages) {
  EXPECT_EQ(p_->tx_messages().size(), 5U);
  EXPECT_EQ(p_->tx("steering")->message->name, "AKit_SteeringRequest");
  EXPECT_TRUE(p_->tx("steering")->message->extended);
  EXPECT_EQ(p_->tx("steering")->message->id, 0x2F03U);
  EXPECT_EQ(p_->tx("accelerator")->signal("throttle")->name, "AKit_AccelPdlReq");
  EXPECT_EQ(p_->tx("brake")->signal("brake")->name, "AKit_BrakePedalReq");
  EXPECT_EQ(p_->tx("steering")->e2e.profile, s::E2eProfile::kCounter);
  EXPECT_EQ(p_->tx("steering")->e2e.counter_byte, 6U);  // AKit_SteerRollingCntr 48|4
  EXPECT_EQ(p_->rx("steering_report")->e2e.counter_byte, 7U);  // DBW_SteeringRollingCntr 56|4
  EXPECT_EQ(p_->rx("misc")->e2e.profile, s::E2eProfile::kNone);
  EXPECT_EQ(p_->limits().name, "eclass_track");
}

TEST_F(NewEagle, BridgeEncodesACommandIntoTheProtocolsFrames) {
  dbw::BridgeCore bridge(*p_);
  Nanos now = 1'000'000'000'000;
  std::uint64_t seq = 0;
  auto command = [&](bool enable) {
    s::Command c;
    c.stamp = now;
    c.seq = ++seq;
    c.enable = enable;
    c.steering_angle = 0.1;  // rad at the road wheels, left
    c.throttle = 0.3;
    c.brake = 0.0;
    c.gear = s::Gear::kDrive;
    bridge.on_command(c, now, now);
  };
  bridge.safety().on_measured(0.1, 0.0);  // the wheel stands at the command (eclass_track rejects steps)
  ecu_ready(bridge, now);
  command(false);
  for (int i = 0; i < 100; ++i) {  // 1 s: the rate limits from the measured state reach the command
    now += 10 * kMs;
    ecu_ready(bridge, now);
    command(true);
  }
  ASSERT_EQ(bridge.safety().state(), s::State::kEngaged);
  std::vector<dbw::can::Frame> frames;
  bridge.frames(now, frames);
  ASSERT_EQ(frames.size(), 5U);
  for (const auto& f : frames) EXPECT_TRUE(f.extended);
  auto v = decode_all(frames);
  EXPECT_EQ(v["AKit_GlobalEnbl.AKit_GlobalByWireEnblReq"], 1.0);
  EXPECT_EQ(v["AKit_SteeringRequest.AKit_SteerCtrlEnblReq"], 1.0);
  EXPECT_EQ(v["AKit_SteeringRequest.AKit_SteeringReqType"], 1.0);
  EXPECT_NEAR(v["AKit_SteeringRequest.AKit_SteeringWhlAngleReq"], 0.1 * kDegPerRoadRad, 0.05 + 1e-9);
  EXPECT_EQ(v["AKit_SteeringRequest.AKit_SteeringChecksum"], 0.0);
  EXPECT_EQ(v["AKit_AccelPdlRequest.AKit_AccelPdlEnblReq"], 1.0);
  EXPECT_EQ(v["AKit_AccelPdlRequest.AKit_AccelReqType"], 0.0);
  EXPECT_NEAR(v["AKit_AccelPdlRequest.AKit_AccelPdlReq"], 30.0, 0.05 + 1e-9);
  EXPECT_EQ(v["AKit_BrakeRequest.AKit_BrakeCtrlEnblReq"], 1.0);
  EXPECT_EQ(v["AKit_BrakeRequest.AKit_BrakePedalReq"], 0.0);
  EXPECT_EQ(v["AKit_PrndRequest.AKit_PrndCtrlEnblReq"], 1.0);
  EXPECT_EQ(v["AKit_PrndRequest.AKit_PrndStateReq"], 4.0);  // Drive
  // Each message counts on its own: the next period's frames all carry counter 1.
  const double first = v["AKit_SteeringRequest.AKit_SteerRollingCntr"];
  frames.clear();
  now += 10 * kMs;
  ecu_ready(bridge, now);
  command(true);
  bridge.frames(now, frames);
  v = decode_all(frames);
  for (const char* c : {"AKit_GlobalEnbl.AKit_GlobalEnblRollingCntr", "AKit_SteeringRequest.AKit_SteerRollingCntr",
                        "AKit_AccelPdlRequest.AKit_AccelPdlRollingCntr", "AKit_BrakeRequest.AKit_BrakeRollingCntr",
                        "AKit_PrndRequest.AKit_PrndRollingCntr"}) {
    EXPECT_EQ(v[c], first + 1) << c;
  }
  // Released: every enable 0 and the neutral request in every message.
  now += 10 * kMs;
  command(false);
  frames.clear();
  bridge.frames(now, frames);
  v = decode_all(frames);
  for (const char* k : {"AKit_GlobalEnbl.AKit_GlobalByWireEnblReq", "AKit_SteeringRequest.AKit_SteerCtrlEnblReq",
                        "AKit_SteeringRequest.AKit_SteeringWhlAngleReq", "AKit_AccelPdlRequest.AKit_AccelPdlEnblReq",
                        "AKit_AccelPdlRequest.AKit_AccelPdlReq", "AKit_BrakeRequest.AKit_BrakeCtrlEnblReq",
                        "AKit_PrndRequest.AKit_PrndCtrlEnblReq", "AKit_PrndRequest.AKit_PrndStateReq"}) {
    EXPECT_EQ(v[k], 0.0) << k;
  }
}

TEST_F(NewEagle, ReportsComeBackInRoleUnits) {
  dbw::BridgeCore bridge(*p_);
  const Nanos now = 1'000'000'000'000;
  const auto* rm = p_->rx("steering_report");
  s::E2eSender counter(rm->e2e);
  dbw::can::Frame f;
  ASSERT_TRUE(p_->encode(*rm, {{"steering_angle", -0.2}}, &counter, f));
  // On the bus: steering-wheel degrees, as the DBC says.
  EXPECT_NEAR(*dbw::dbc::decode(*rm->message->find("DBW_SteeringWhlAngleAct"), f.payload()), -0.2 * kDegPerRoadRad, 0.05 + 1e-9);
  EXPECT_EQ(bridge.on_frame({f, now}, now), dbw::RxKind::kFeedback);
  EXPECT_NEAR(bridge.feedback().steering_angle, -0.2, 0.05 / kDegPerRoadRad + 1e-9);
  ASSERT_TRUE(p_->encode(*p_->rx("misc"), {{"ready", 1}, {"override", 1}, {"speed", 12.5}}, nullptr, f));
  bridge.on_frame({f, now}, now);
  EXPECT_TRUE(bridge.ecu().ready);
  EXPECT_TRUE(bridge.ecu().override);
  EXPECT_NEAR(bridge.feedback().speed, 12.5, 0.0022);
}

}  // namespace
