// The mock ECU in-process: engages on valid PU frames, drives the bicycle model, checks E2E and
// timeouts like a real ECU, and injects each fault.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <map>
#include <thread>

#include "dbw_test_data.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/can/transport.hpp"
#include "sensor_rig/dbw/mock/mock_ecu.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"

namespace dbw = sensor_rig::dbw;
namespace mock = sensor_rig::dbw::mock;
namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;
using sensor_rig::kMs;

namespace {

class MockEcuTest : public ::testing::Test {
 protected:
  dbw::Protocol p_ = dbw::Protocol::load((dbw::test::source_dir() / "config/dbw/paravan_ref.yaml").string());
  s::E2eSender steer_{p_.tx("steering")->e2e};
  s::E2eSender lon_{p_.tx("longitudinal")->e2e};
  s::E2eSender hb_{p_.tx("heartbeat")->e2e};
  Nanos now_ = 1'000'000'000;

  // One 10 ms PU cycle then 10 model steps of 1 ms; returns the ECU's frames.
  std::vector<dbw::can::Frame> cycle(mock::MockEcu& ecu, bool enable, double steer_rad, double throttle,
                                     bool corrupt = false, bool heartbeat = true) {
    dbw::can::Frame f;
    EXPECT_TRUE(p_.encode(*p_.tx("steering"), {{"enable", enable ? 1 : 0}, {"angle", steer_rad}}, &steer_, f));
    if (corrupt) f.data[0] ^= 0xFF;
    ecu.on_frame(f, now_);
    EXPECT_TRUE(p_.encode(*p_.tx("longitudinal"), {{"enable", enable ? 1 : 0}, {"throttle", throttle}, {"gear", 4}}, &lon_, f));
    ecu.on_frame(f, now_);
    if (heartbeat) {
      EXPECT_TRUE(p_.encode(*p_.tx("heartbeat"), {{"state", enable ? 1 : 0}}, &hb_, f));
      ecu.on_frame(f, now_);
    }
    std::vector<dbw::can::Frame> out;
    for (int i = 0; i < 10; ++i) {
      now_ += kMs;
      auto v = ecu.step(now_);
      out.insert(out.end(), v.begin(), v.end());
    }
    return out;
  }
};

TEST_F(MockEcuTest, EngagesAndDrivesTheModel) {
  mock::MockEcu ecu(p_, {});
  cycle(ecu, false, 0, 0);
  for (int i = 0; i < 200; ++i) cycle(ecu, true, 0.2, 0.5);  // 2 s
  EXPECT_TRUE(ecu.engaged());
  const auto& st = ecu.model().state();
  EXPECT_GT(st.speed, 1.5);
  EXPECT_NEAR(st.steer, 0.2, 0.01);
  EXPECT_GT(st.yaw, 0.0);  // turning left
  EXPECT_NEAR(st.yaw_rate, st.speed * std::tan(st.steer) / 2.94, 1e-9);
  // Status/feedback frames decode and pass the PU's E2E check.
  s::E2eChecker chk(p_.rx("feedback")->e2e);
  int feedback = 0;
  for (const auto& f : cycle(ecu, true, 0.2, 0.5)) {
    if (!p_.rx("feedback")->matches(f)) continue;
    ++feedback;
    EXPECT_TRUE(s::is_ok(chk.check(f.payload())));
    EXPECT_NEAR(*dbw::Protocol::value(*p_.rx("feedback"), "speed", f), ecu.model().state().speed, 0.1);
  }
  EXPECT_EQ(feedback, 1);
}

TEST_F(MockEcuTest, DisengagesOnPuSilenceAndBadE2e) {
  mock::MockEcu ecu(p_, {});
  cycle(ecu, false, 0, 0);
  cycle(ecu, true, 0, 0.2);
  ASSERT_TRUE(ecu.engaged());
  for (int i = 0; i < 101; ++i) {
    now_ += kMs;
    ecu.step(now_);
  }
  EXPECT_FALSE(ecu.engaged());
  EXPECT_EQ(ecu.last_disengage(), "pu timeout");
  cycle(ecu, false, 0, 0);
  cycle(ecu, true, 0, 0.2);
  ASSERT_TRUE(ecu.engaged());
  for (int i = 0; i < 5; ++i) cycle(ecu, true, 0, 0.2, true);
  EXPECT_FALSE(ecu.engaged());
  EXPECT_GE(ecu.counters().rx_e2e_errors, 4U);
}

TEST_F(MockEcuTest, OnlyThePuHeartbeatStoppingDisengagesAndIsReported) {
  mock::MockEcu ecu(p_, {});
  cycle(ecu, false, 0, 0);
  cycle(ecu, true, 0.1, 0.2);
  ASSERT_TRUE(ecu.engaged());
  auto reported_engaged = [&](const std::vector<dbw::can::Frame>& frames) {
    double v = -1;
    for (const auto& f : frames) {
      if (p_.rx("status")->matches(f)) v = *dbw::Protocol::value(*p_.rx("status"), "engaged", f);
    }
    return v;
  };
  // Commands go on (valid, fresh, enabled); only the heartbeat is missing.
  EXPECT_DOUBLE_EQ(reported_engaged(cycle(ecu, true, 0.1, 0.2)), 1.0);
  int cycles = 0;
  while (ecu.engaged() && cycles < 30) {
    cycle(ecu, true, 0.1, 0.2, false, false);
    ++cycles;
  }
  EXPECT_FALSE(ecu.engaged());
  EXPECT_GE(cycles, 10) << "disengaged before the heartbeat timeout";
  EXPECT_LE(cycles, 12) << "the heartbeat timeout is 100 ms";
  EXPECT_EQ(ecu.last_disengage(), "pu timeout");
  EXPECT_EQ(ecu.counters().pu_timeouts, 1U);
  EXPECT_DOUBLE_EQ(reported_engaged(cycle(ecu, true, 0.1, 0.2, false, false)), 0.0) << "status must report it";
  // Heartbeat back with enable held: no re-engagement without a new enable edge.
  for (int i = 0; i < 5; ++i) cycle(ecu, true, 0.1, 0.2);
  EXPECT_FALSE(ecu.engaged());
  cycle(ecu, false, 0, 0);
  cycle(ecu, true, 0.1, 0.2);
  EXPECT_TRUE(ecu.engaged());
}

TEST_F(MockEcuTest, NoStatusFaultSilencesOnlyTheStatusMessage) {
  mock::MockEcu ecu(p_, {mock::parse_fault("no-status@0.1+0.1")});
  std::map<std::string, int> during, outside;
  for (int c = 0; c < 30; ++c) {
    const double t = (c + 1) * 0.01;  // end of this cycle, ECU time
    for (const auto& f : cycle(ecu, false, 0, 0)) {
      auto& m = t > 0.11 && t <= 0.2 ? during : outside;
      for (const auto& rm : p_.rx_messages()) {
        if (rm.matches(f)) ++m[rm.role];
      }
    }
  }
  EXPECT_EQ(during["status"], 0);
  EXPECT_GE(during["feedback"], 8);
  EXPECT_GE(outside["status"], 18);
}

TEST_F(MockEcuTest, InjectedFaultsShowOnTheBus) {
  mock::MockEcu ecu(p_, {mock::parse_fault("bad-crc@0.1+0.05"), mock::parse_fault("stuck-counter@0.2+0.05"),
                        mock::parse_fault("override@0.3+0.05"), mock::parse_fault("ecu-fault@0.4+0.05"),
                        mock::parse_fault("bus-off@0.5+0.05")});
  s::E2eChecker chk(p_.rx("status")->e2e);
  std::map<std::string, int> seen;
  for (int c = 0; c < 60; ++c) {
    const double t = c * 0.01;
    for (const auto& f : cycle(ecu, true, 0, 0)) {
      if (f.error) {
        const auto e = dbw::can::classify_error_frame(f);
        if (e.bus_off) ++seen["bus_off"];
        if (e.restarted) ++seen["restarted"];
        continue;
      }
      if (!p_.rx("status")->matches(f)) continue;
      const auto st = chk.check(f.payload());
      if (st == s::E2eStatus::kBadCrc) ++seen["bad_crc@" + std::to_string(static_cast<int>(t * 10))];
      if (st == s::E2eStatus::kRepeated) ++seen["repeated"];
      if (*dbw::Protocol::value(*p_.rx("status"), "override", f) > 0.5) ++seen["override"];
      if (*dbw::Protocol::value(*p_.rx("status"), "fault", f) > 0.5) ++seen["fault"];
      if (t > 0.5 && t < 0.55) ++seen["during_bus_off"];
    }
  }
  EXPECT_GE(seen["bad_crc@1"], 3);
  EXPECT_GE(seen["repeated"], 3);
  EXPECT_GE(seen["override"], 3);
  EXPECT_GE(seen["fault"], 3);
  EXPECT_EQ(seen["bus_off"], 1);
  EXPECT_EQ(seen["restarted"], 1);
  EXPECT_EQ(seen["during_bus_off"], 0);
}

// The truth of a frozen counter (rig chaos holds the bridge's counts against it): every status frame
// the receiver's E2E check finds repeating its predecessor's counter is recorded kRepeatedCounter,
// and every frame recorded kSent passes it. Before, the counter stayed frozen one frame past the
// fault: the first frame after it repeated the frozen value and was recorded sent.
TEST_F(MockEcuTest, EveryFrameRepeatingTheCounterIsRecordedSoAndNoneAfterTheFault) {
  mock::MockEcu ecu(p_, {mock::parse_fault("stuck-counter@0.2+0.05"), mock::parse_fault("stuck-counter@0.4+0.03")});
  std::vector<mock::EmittedFrame::Fate> fates;  // the status frames', in order
  ecu.set_observer([&](const mock::EmittedFrame& e) {
    if (e.role == "status") fates.push_back(e.fate);
  });
  s::E2eChecker chk(p_.rx("status")->e2e);
  std::vector<s::E2eStatus> verdicts;
  for (int c = 0; c < 60; ++c)
    for (const auto& f : cycle(ecu, true, 0, 0))
      if (!f.error && p_.rx("status")->matches(f)) verdicts.push_back(chk.check(f.payload()));
  ASSERT_EQ(fates.size(), verdicts.size());
  int repeated = 0;
  for (std::size_t i = 0; i < fates.size(); ++i) {
    const bool said_repeated = fates[i] == mock::EmittedFrame::Fate::kRepeatedCounter;
    EXPECT_EQ(verdicts[i] == s::E2eStatus::kRepeated, said_repeated) << "status frame " << i;
    if (fates[i] == mock::EmittedFrame::Fate::kSent) {
      EXPECT_EQ(verdicts[i], s::E2eStatus::kOk) << "status frame " << i;
    }
    repeated += said_repeated ? 1 : 0;
  }
  EXPECT_GE(repeated, 5);  // the two faults' frames but their first
}

TEST_F(MockEcuTest, FrameLossDropsAboutTheConfiguredShare) {
  mock::MockEcu ecu(p_, {mock::parse_fault("loss=0.5")}, 7);
  for (int c = 0; c < 200; ++c) cycle(ecu, false, 0, 0);
  const double total = static_cast<double>(ecu.counters().tx_frames + ecu.counters().tx_dropped);
  EXPECT_NEAR(static_cast<double>(ecu.counters().tx_dropped) / total, 0.5, 0.08);
}

TEST(MockFaults, ParseSpecs) {
  const auto f = mock::parse_fault("bus-off@5+0.3");
  EXPECT_EQ(f.kind, mock::FaultKind::kBusOff);
  EXPECT_DOUBLE_EQ(f.start_s, 5.0);
  EXPECT_DOUBLE_EQ(f.duration_s, 0.3);
  EXPECT_TRUE(f.active(5.1));
  EXPECT_FALSE(f.active(5.3));
  EXPECT_DOUBLE_EQ(mock::parse_fault("loss=0.25").value, 0.25);
  EXPECT_EQ(mock::parse_fault("no-status@1+0.2").kind, mock::FaultKind::kNoStatus);
  EXPECT_THROW(mock::parse_fault("melt"), std::invalid_argument);
  EXPECT_THROW(mock::parse_fault("loss=2"), std::invalid_argument);
  EXPECT_THROW(mock::parse_fault("override@x"), std::invalid_argument);
}

}  // namespace

// The truth of a frame the mock hands to the bus (`rig chaos` matches each /vehicle/state sample to
// it by the bridge's kernel receive stamp) is the send's bracket: the clock just before the send and
// just after it returned. A process stalled after its send (descheduled on a loaded host, or
// SIGSTOPped by host.stall_mock) put a truth taken after it 5-300 ms past the kernel's stamp
// ("matches no can_frame"); one stalled before it put a truth taken before it 5 ms ahead of the
// stamp, and the judge gave the sample the next frame ("published twice", CI, dbw campaign seed 4).
// Here the bus stalls the sender 20 ms before each frame is queued to the peer and 20 ms after.
namespace {
class StallingAroundSend final : public dbw::can::Transport {
 public:
  static constexpr auto kStall = std::chrono::milliseconds(20);
  explicit StallingAroundSend(std::unique_ptr<dbw::can::Transport> inner) : inner_(std::move(inner)) {}
  dbw::can::IoStatus send(const dbw::can::Frame& f) noexcept override {
    std::this_thread::sleep_for(kStall);  // descheduled before the send
    const auto st = inner_->send(f);
    std::this_thread::sleep_for(kStall);  // queued to the peer, then descheduled
    return st;
  }
  dbw::can::IoStatus receive(dbw::can::RxFrame& out, int timeout_ms) noexcept override { return inner_->receive(out, timeout_ms); }
  [[nodiscard]] int poll_fd() const noexcept override { return inner_->poll_fd(); }
  [[nodiscard]] std::string name() const override { return "stalling " + inner_->name(); }

 private:
  std::unique_ptr<dbw::can::Transport> inner_;
};
}  // namespace

TEST_F(MockEcuTest, AFrameIsStampedInsideTheSendItsTruthBrackets) {
  auto [ecu_end, peer] = dbw::can::make_socketpair();
  StallingAroundSend bus(std::move(ecu_end));
  mock::MockEcu ecu(p_, {});
  std::vector<std::pair<Nanos, Nanos>> sends;  // handed, returned
  mock::RunOptions o;
  o.duration_s = 0.3;
  o.on_sent = [&](const dbw::can::Frame&, bool heard, Nanos handed_ns, Nanos returned_ns) {
    EXPECT_TRUE(heard);
    sends.emplace_back(handed_ns, returned_ns);
  };
  (void)mock::run_mock(ecu, bus, o);
  std::vector<Nanos> received;
  dbw::can::RxFrame rx;
  while (peer->receive(rx, 0) == dbw::can::IoStatus::kOk) received.push_back(rx.stamp);
  ASSERT_GE(sends.size(), 3U) << "the ECU sends status frames on its own";
  ASSERT_EQ(received.size(), sends.size());
  const Nanos stall = std::chrono::duration_cast<std::chrono::nanoseconds>(StallingAroundSend::kStall).count();
  for (std::size_t i = 0; i < sends.size(); ++i) {
    // The kernel stamps the frame when it is queued: inside the bracket, a stall from either end.
    EXPECT_LE(sends[i].first + stall, received[i]) << "frame " << i;
    EXPECT_LE(received[i] + stall, sends[i].second) << "frame " << i;
    if (i > 0) {
      EXPECT_LE(sends[i - 1].second, sends[i].first) << "brackets of one sender never overlap";
    }
  }
}
