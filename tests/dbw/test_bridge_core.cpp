// Bridge core against the mock ECU in one process, frames passed directly (fake clock): the whole
// command path (safety -> encoder -> E2E -> ECU -> model -> feedback) and each fault's reaction.
#include <gtest/gtest.h>

#include "dbw_test_data.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dbw/mock/mock_ecu.hpp"

namespace dbw = sensor_rig::dbw;
namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;
using sensor_rig::kMs;

namespace {

struct Loop {
  dbw::Protocol p = dbw::Protocol::load((dbw::test::source_dir() / "config/dbw/paravan_ref.yaml").string());
  dbw::BridgeCore bridge{p};
  dbw::mock::MockEcu ecu;
  Nanos now = 1'000'000'000'000;
  std::uint64_t seq = 0;
  std::vector<dbw::can::Frame> last_tx;
  explicit Loop(std::vector<dbw::mock::Fault> faults = {}) : ecu(p, std::move(faults)) {}

  // 10 ms: optional command, bridge frames -> ECU, ECU frames -> bridge.
  void cycle(bool send_cmd, bool enable, double throttle = 0.3, double steer = 0.1) {
    if (send_cmd) {
      s::Command c;
      c.stamp = now;
      c.seq = ++seq;
      c.enable = enable;
      c.throttle = throttle;
      c.steering_angle = steer;
      c.gear = s::Gear::kDrive;
      bridge.on_command(c, now, now);
    }
    last_tx.clear();
    bridge.frames(now, last_tx);
    if (bus_off) {
      refused += last_tx.size();  // as the transport does: refused, not queued
      last_tx.clear();
    }
    for (const auto& f : last_tx) ecu.on_frame(f, now);
    for (int i = 0; i < 10; ++i) {
      now += kMs;
      for (const auto& f : ecu.step(now)) {
        dbw::can::RxFrame rx{f, now};
        bridge.on_frame(rx, now);
        if (f.error) {
          bus_off = dbw::can::classify_error_frame(f).bus_off;
          bridge.on_bus_state(bus_off ? dbw::can::BusState::kBusOff : dbw::can::BusState::kActive, now);
        }
      }
    }
  }
  bool bus_off = false;
  std::size_t refused = 0;
  double tx_enable() {
    for (const auto& f : last_tx) {
      if (p.tx("steering")->matches(f)) return *dbw::Protocol::value(*p.tx("steering"), "enable", f);
    }
    return -1;
  }
};

TEST(BridgeLoop, CommandsMoveTheVehicleAndFeedbackReturns) {
  Loop l;
  for (int i = 0; i < 5; ++i) l.cycle(true, false);
  for (int i = 0; i < 200; ++i) l.cycle(true, true);
  EXPECT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  EXPECT_TRUE(l.ecu.engaged());
  EXPECT_TRUE(l.bridge.ecu().engaged);
  EXPECT_DOUBLE_EQ(l.tx_enable(), 1.0);
  EXPECT_GT(l.bridge.feedback().speed, 1.0);
  EXPECT_NEAR(l.bridge.feedback().speed, l.ecu.model().state().speed, 0.2);
  EXPECT_NEAR(l.bridge.feedback().steering_angle, 0.1, 0.01);
  EXPECT_GT(l.bridge.feedback().wheels[0], 0.5);
  EXPECT_EQ(l.bridge.safety().counters().e2e_errors, 0U);
}

TEST(BridgeLoop, CommandSilenceSendsNeutralWithinOnePeriodOfTheTimeout) {
  Loop l;
  l.cycle(true, false);
  for (int i = 0; i < 20; ++i) l.cycle(true, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  const Nanos last_cmd = l.now - 10 * kMs;
  Nanos first_neutral = 0;
  for (int i = 0; i < 20 && first_neutral == 0; ++i) {
    l.cycle(false, true);
    if (l.tx_enable() == 0.0) first_neutral = l.now - 10 * kMs;
  }
  ASSERT_GT(first_neutral, 0);
  EXPECT_LE(first_neutral - last_cmd, 100 * kMs + 10 * kMs);
  EXPECT_EQ(l.bridge.safety().reason(), s::Reason::kCommandTimeout);
  for (int i = 0; i < 3; ++i) l.cycle(false, true);
  EXPECT_FALSE(l.ecu.engaged());
}

// Every command message of the last cycle decodes to the protocol's neutral request (enable 0,
// zero steering angle/torque, zero pedals and acceleration, gear "keep"), and the heartbeat reports
// disengaged. Returns how many command frames were checked.
int expect_all_neutral(const Loop& l) {
  int checked = 0;
  for (const auto& f : l.last_tx) {
    for (const auto& rm : l.p.tx_messages()) {
      if (!rm.matches(f)) continue;
      for (const auto& [role, sig] : rm.signals) {
        EXPECT_DOUBLE_EQ(*dbw::Protocol::value(rm, role, f), 0.0) << rm.role << "." << role;
      }
      if (rm.role != "heartbeat") ++checked;
    }
  }
  return checked;
}

struct FaultCase {
  const char* fault;
  s::Reason reason;
};

class BridgeFaults : public ::testing::TestWithParam<FaultCase> {};

TEST_P(BridgeFaults, EachInjectedFaultDisengagesWithItsReason) {
  Loop l({dbw::mock::parse_fault(GetParam().fault)});
  l.cycle(true, false);
  l.cycle(true, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  for (int i = 0; i < 100 && l.bridge.safety().state() == s::State::kEngaged; ++i) l.cycle(true, true);
  EXPECT_EQ(l.bridge.safety().state(), s::State::kDisengaged);
  EXPECT_EQ(l.bridge.safety().reason(), GetParam().reason);
  // Enable held, fresh commands: the disengage latches and only neutral frames go out.
  for (int i = 0; i < 3; ++i) {
    l.cycle(true, true);
    EXPECT_EQ(l.bridge.safety().state(), s::State::kDisengaged) << i;
    if (!l.bus_off) {
      EXPECT_EQ(expect_all_neutral(l), 2) << i;
      EXPECT_DOUBLE_EQ(l.tx_enable(), 0.0);
    }
  }
  EXPECT_FALSE(l.ecu.engaged());
}

TEST(BridgeLoop, AfterBusOffRecoveryOnlyNeutralFramesUntilANewEnableEdge) {
  Loop l({dbw::mock::parse_fault("bus-off@0.2+0.3")});
  l.cycle(true, false);
  for (int i = 0; i < 10; ++i) l.cycle(true, true, 0.3, 0.1);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  ASSERT_DOUBLE_EQ(l.tx_enable(), 1.0);
  int cycles = 0;
  while (!l.bus_off && cycles++ < 50) l.cycle(true, true, 0.5, 0.2);  // the command changes as the bus drops
  ASSERT_TRUE(l.bus_off);
  EXPECT_EQ(l.bridge.safety().reason(), s::Reason::kBusOff);
  // Bus-off: fresh enabled commands keep coming; every frame is refused.
  cycles = 0;
  while (l.bus_off && cycles++ < 50) l.cycle(true, true, 0.5, 0.2);
  ASSERT_FALSE(l.bus_off) << "the bus did not recover";
  EXPECT_GE(l.refused, 3U * 20U) << "the bridge kept transmitting (refused) while bus-off";
  // Recovered: the first frames out are neutral, not the command of the bus-off period.
  for (int i = 0; i < 5; ++i) {
    l.cycle(true, true, 0.5, 0.2);
    EXPECT_EQ(l.bridge.safety().state(), s::State::kDisengaged) << i;
    EXPECT_EQ(expect_all_neutral(l), 2) << i;
  }
  EXPECT_FALSE(l.ecu.engaged());
  // A new enable edge engages again, ramping from the released pedal toward the current command.
  l.cycle(true, false, 0.5, 0.2);
  EXPECT_EQ(expect_all_neutral(l), 2);
  l.cycle(true, true, 0.5, 0.2);
  EXPECT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  EXPECT_DOUBLE_EQ(l.tx_enable(), 1.0);
  const auto* lon = l.p.tx("longitudinal");
  const double slew = l.p.limits()[s::Axis::kThrottle].max_rate * 0.010;
  int seen = 0;
  for (const auto& f : l.last_tx) {
    if (lon->matches(f)) {
      ++seen;
      const double t = *dbw::Protocol::value(*lon, "throttle", f);
      EXPECT_GT(t, 0.0);
      EXPECT_LE(t, slew + 0.01) << "engaged with a step, not from the measured state";
    }
  }
  EXPECT_EQ(seen, 1);
  for (int i = 0; i < 3; ++i) l.cycle(true, true, 0.5, 0.2);
  EXPECT_TRUE(l.ecu.engaged());
}

INSTANTIATE_TEST_SUITE_P(All, BridgeFaults,
                         ::testing::Values(FaultCase{"override@0.2", s::Reason::kDriverOverride},
                                           FaultCase{"ecu-fault@0.2", s::Reason::kEcuFault},
                                           FaultCase{"bad-crc@0.2", s::Reason::kE2eErrors},
                                           FaultCase{"stuck-counter@0.2", s::Reason::kE2eErrors},
                                           FaultCase{"bus-off@0.2+0.3", s::Reason::kBusOff},
                                           FaultCase{"loss=1@0.2", s::Reason::kEcuTimeout},
                                           FaultCase{"no-status@0.2", s::Reason::kEcuTimeout}));

}  // namespace
