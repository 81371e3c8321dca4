#pragma once
// The fixture of the safety core's typed suite: the core with a fake clock, run by every vehicle's
// limit table (opendbc style). SafetySuite's tests are split by section over test_safety_*.cpp (one
// test_dbw_safety binary). gtest needs one fixture type per suite name across the binary, so the
// fixture and the vehicle types live here in a named namespace, not in each file's anonymous one.
#include <gtest/gtest.h>

#include <cstdint>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/safety/safety_core.hpp"

namespace sensor_rig::dbw::safety::test {

namespace s = sensor_rig::dbw::safety;
using sensor_rig::Nanos;

struct ParavanRef {
  static constexpr const s::VehicleLimits& kLimits = s::kParavanRef;
};
struct EClassTrack {
  static constexpr const s::VehicleLimits& kLimits = s::kEClassTrack;
};

template <class V>
class SafetySuite : public ::testing::Test {
 public:
  // The wheel stands where the commands below ask it to be: engaging needs no step (a table that
  // rejects rate violations refuses to jump from the measured angle).
  SafetySuite() { core.on_measured(0.1 * V::kLimits[s::Axis::kSteeringAngle].max, 0.0); }
  s::SafetyConfig cfg() {
    s::SafetyConfig c;
    c.limits = V::kLimits;
    return c;
  }
  s::SafetyCore core{cfg()};
  Nanos now = 1'000'000'000'000;  // the bridge's monotonic clock
  Nanos offset = 7'000'000'000;   // vehicle time - monotonic time (stepped by clock corrections)
  std::uint64_t seq = 0;

  Nanos vnow() const { return now + offset; }
  s::Command cmd(bool enable, s::WriterId writer = 0) {
    s::Command c;
    c.stamp = vnow();
    c.seq = ++seq;
    c.writer = writer;
    c.enable = enable;
    c.steering_angle = 0.1 * V::kLimits[s::Axis::kSteeringAngle].max;
    c.throttle = 0.1;
    return c;
  }
  void send(const s::Command& c) { core.on_command(c, now, vnow()); }
  void ecu_ok() { core.on_ecu_status({true, false, false, false, 0}, now); }
  void step(Nanos dt) { now += dt; }
  // Steady 10 ms cycle: ECU status + command.
  void cycle(bool enable) {
    step(10 * kMs);
    ecu_ok();
    send(cmd(enable));
  }
  void engage() {
    cycle(false);
    cycle(true);
    ASSERT_EQ(core.state(), s::State::kEngaged);
    core.take_events();
  }
  s::Reason last_transition_reason() {
    s::Reason r = s::Reason::kNone;
    for (const auto& e : core.take_events()) {
      if (e.kind == s::EventKind::kTransition) r = e.reason;
    }
    return r;
  }
};

using Vehicles = ::testing::Types<ParavanRef, EClassTrack>;
TYPED_TEST_SUITE(SafetySuite, Vehicles);

}  // namespace sensor_rig::dbw::safety::test
