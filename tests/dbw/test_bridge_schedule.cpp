// When the bridge transmits, driven as the node drives it (a 1 ms CAN tick plus commands as they
// arrive, BridgeCore::transmit_due deciding): frames follow the bus schedule whatever the command
// rate, a disengage caused by an ECU frame leaves in that same tick, and stopping sends neutral.
#include <gtest/gtest.h>

#include "dbw_test_data.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dbw/mock/mock_ecu.hpp"

namespace dbw = sensor_rig::dbw;
namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;
using sensor_rig::kUs;
using sensor_rig::kMs;

namespace {

struct Sent {
  Nanos t = 0;
  double enable = -1;
};

struct TickLoop {
  dbw::Protocol p = dbw::Protocol::load((dbw::test::source_dir() / "config/dbw/paravan_ref.yaml").string());
  dbw::BridgeCore bridge{p};
  dbw::mock::MockEcu ecu;
  Nanos now = 1'000'000'000'000;
  Nanos next_tick = now;
  std::uint64_t seq = 0;
  std::vector<Sent> sets;        // every frame set the bridge put on the bus
  Nanos last_status_rx = 0;      // the ECU status frame most recently handed to the bridge
  explicit TickLoop(std::vector<dbw::mock::Fault> faults = {}) : ecu(p, std::move(faults)) {}

  void transmit() {
    std::vector<dbw::can::Frame> out;
    bridge.frames(now, out);
    Sent st{now, -1};
    for (const auto& f : out) {
      ecu.on_frame(f, now);
      if (p.tx("steering")->matches(f)) st.enable = *dbw::Protocol::value(*p.tx("steering"), "enable", f);
    }
    sets.push_back(st);
  }
  void command(bool enable) {
    s::Command c;
    c.stamp = now;
    c.seq = ++seq;
    c.enable = enable;
    c.throttle = 0.1 + 1e-4 * static_cast<double>(seq % 100);  // every command changes something
    c.steering_angle = 0.0;
    if (bridge.transmit_due(now, bridge.on_command(c, now, now))) transmit();
  }
  // Advances to `until`, the CAN thread's 1 ms tick (ECU frames in, then transmit_due).
  void run_until(Nanos until) {
    while (next_tick <= until) {
      now = next_tick;
      for (const auto& f : ecu.step(now)) {
        if (bridge.on_frame({f, now}, now) == dbw::RxKind::kStatus) last_status_rx = now;
      }
      if (bridge.transmit_due(now, false)) transmit();
      next_tick += kMs;
    }
    now = until;
  }
  // Commands every `interval` from now until `until`, the tick running in between.
  void drive(Nanos interval, Nanos until, bool enable) {
    for (Nanos t = now + interval / 2 + 300 * kUs; t < until; t += interval) {  // between ticks
      run_until(t);
      command(enable);
    }
    run_until(until);
  }
};

TEST(BridgeSchedule, AHundredHertzSourceGoesOutAtOnceEveryTime) {
  TickLoop l;
  l.drive(10 * kMs, l.now + 100 * kMs, false);
  l.drive(10 * kMs, l.now + 1000 * kMs, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  EXPECT_EQ(l.bridge.counters().commands_deferred, 0U) << "a command at the bus rate waited";
  // Each command left when it arrived (half way between ticks), not at a tick.
  int at_command = 0;
  for (const auto& st : l.sets) at_command += (st.t % kMs) != 0 ? 1 : 0;
  EXPECT_GE(at_command, 99);  // the 100 enabled commands (disabled ones change nothing: periodic)
}

TEST(BridgeSchedule, AFiveKilohertzFloodStaysOnTheBusSchedule) {
  TickLoop l;
  l.drive(10 * kMs, l.now + 100 * kMs, false);
  l.drive(10 * kMs, l.now + 50 * kMs, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  const std::size_t before = l.sets.size();
  const Nanos start = l.now;
  l.drive(200 * kUs, l.now + 1000 * kMs, true);  // 5 kHz for 1 s
  const std::size_t sets = l.sets.size() - before;
  const dbw::TxSchedule schedule(l.p.timing().tx_period_ns);
  const auto spacing = schedule.command_spacing();  // 4/5 of the period
  EXPECT_LE(sets, static_cast<std::size_t>(1000 * kMs / spacing) + 1) << "more frame sets than the bus schedule allows";
  EXPECT_GE(sets, static_cast<std::size_t>(1000 * kMs / spacing) - 3) << "the commands did not go out at the schedule's rate";
  EXPECT_GT(l.bridge.counters().commands_deferred, 4000U);
  for (std::size_t i = before + 1; i < l.sets.size(); ++i) {
    EXPECT_GE(l.sets[i].t - l.sets[i - 1].t, spacing) << "sets too close at +" << (l.sets[i].t - start) / kMs << " ms";
  }
  EXPECT_EQ(l.bridge.safety().state(), s::State::kEngaged);
}

TEST(BridgeSchedule, EcuTriggeredDisengageLeavesInTheSameTick) {
  TickLoop l({dbw::mock::parse_fault("override@0.5")});
  l.drive(10 * kMs, l.now + 100 * kMs, false);
  l.drive(10 * kMs, l.now + 300 * kMs, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  Nanos disengaged_at = 0;
  std::size_t first_after = 0;
  // Step the loop tick by tick; note the tick whose ECU frame disengaged.
  for (int i = 0; i < 1000 && disengaged_at == 0; ++i) {
    const std::size_t n = l.sets.size();
    l.run_until(l.now + kMs);
    if (l.bridge.safety().state() == s::State::kDisengaged) {
      disengaged_at = l.now;
      first_after = n;
    }
    if (i % 10 == 5) l.command(true);
  }
  ASSERT_GT(disengaged_at, 0);
  ASSERT_EQ(l.bridge.safety().reason(), s::Reason::kDriverOverride);
  ASSERT_LT(first_after, l.sets.size()) << "no frame set in the tick of the disengage";
  EXPECT_EQ(l.sets[first_after].t, l.last_status_rx) << "the neutral frame waited for the period";
  EXPECT_DOUBLE_EQ(l.sets[first_after].enable, 0.0);
}

TEST(BridgeSchedule, StopSendsNeutralAndNeverEngagesAgain) {
  TickLoop l;
  l.drive(10 * kMs, l.now + 100 * kMs, false);
  l.drive(10 * kMs, l.now + 300 * kMs, true);
  ASSERT_EQ(l.bridge.safety().state(), s::State::kEngaged);
  l.bridge.safety().shutdown(l.now);
  ASSERT_TRUE(l.bridge.transmit_due(l.now, false));
  l.transmit();
  EXPECT_DOUBLE_EQ(l.sets.back().enable, 0.0);
  l.drive(10 * kMs, l.now + 50 * kMs, false);
  l.drive(10 * kMs, l.now + 100 * kMs, true);
  for (const auto& st : l.sets) {
    if (st.t > l.now - 150 * kMs) {
      EXPECT_DOUBLE_EQ(st.enable, 0.0);
    }
  }
}

}  // namespace
