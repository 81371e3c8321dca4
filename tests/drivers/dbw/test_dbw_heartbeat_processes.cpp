// The PU heartbeat across processes: the test plays the PU on `rig mock paravan`'s unix bus. With
// valid, fresh, enabled steering and longitudinal requests still coming, stopping only the
// PRV_PU_HEARTBEAT makes the ECU disengage after its timeout and report it in its status.
#include <gtest/gtest.h>

#include <string>

#include "dbw_processes.hpp"
#include "dbw_test_data.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace dbw = sensor_rig::dbw;
using sensor_rig::monotonic_now_ns;
using sensor_rig::Nanos;
using sensor_rig::kMs;

namespace {

struct Pu {
  const dbw::Protocol& p;
  dbw::can::Transport& bus;
  dbw::safety::E2eSender steer{p.tx("steering")->e2e};
  dbw::safety::E2eSender lon{p.tx("longitudinal")->e2e};
  dbw::safety::E2eSender hb{p.tx("heartbeat")->e2e};
  double ecu_engaged = -1;  // from the latest ECU status
  Nanos status_at = 0;

  void send(const char* role, std::initializer_list<std::pair<std::string_view, double>> v, dbw::safety::E2eSender& s) {
    dbw::can::Frame f;
    ASSERT_TRUE(p.encode(*p.tx(role), v, &s, f));
    ASSERT_EQ(bus.send(f), dbw::can::IoStatus::kOk);
  }
  // One 10 ms PU period: requests (and the heartbeat unless `silent_heartbeat`), then ECU frames.
  void period(bool enable, bool heartbeat) {
    const double en = enable ? 1 : 0;
    send("steering", {{"enable", en}, {"angle", 0.05}}, steer);
    send("longitudinal", {{"enable", en}, {"throttle", 0.1}, {"gear", 4}}, lon);
    if (heartbeat) send("heartbeat", {{"state", en}}, hb);
    const Nanos end = monotonic_now_ns() + 10 * kMs;
    dbw::can::RxFrame rx;
    for (Nanos now = monotonic_now_ns(); now < end; now = monotonic_now_ns()) {
      if (bus.receive(rx, static_cast<int>((end - now) / kMs) + 1) != dbw::can::IoStatus::kOk) continue;
      if (!p.rx("status")->matches(rx.frame)) continue;
      ecu_engaged = dbw::Protocol::value(*p.rx("status"), "engaged", rx.frame).value_or(-1);
      status_at = monotonic_now_ns();
    }
  }
};

TEST(DbwHeartbeatProcesses, MockEcuDisengagesWhenOnlyThePuHeartbeatStops) {
  dbw::test::RigProcesses rig("dbw_hb");
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
  const pid_t mock = rig.start_mock({"--duration", "10"});
  ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
  const auto p = dbw::Protocol::load((dbw::test::source_dir() / "config/dbw/paravan_ref.yaml").string());
  auto bus = dbw::can::open_transport(rig.bus());
  Pu pu{p, *bus};

  for (int i = 0; i < 5; ++i) pu.period(false, true);
  for (int i = 0; i < 50 && pu.ecu_engaged != 1.0; ++i) pu.period(true, true);
  ASSERT_EQ(pu.ecu_engaged, 1.0) << "the mock ECU did not engage";
  for (int i = 0; i < 10; ++i) pu.period(true, true);
  ASSERT_EQ(pu.ecu_engaged, 1.0);

  const Nanos last_heartbeat = monotonic_now_ns() - 10 * kMs;
  for (int i = 0; i < 60 && pu.ecu_engaged == 1.0; ++i) pu.period(true, false);
  EXPECT_EQ(pu.ecu_engaged, 0.0) << "the ECU kept actuating without the PU heartbeat";
  const Nanos reported_after = pu.status_at - last_heartbeat;
  EXPECT_GE(reported_after, 90 * kMs) << "disengaged before the 100 ms heartbeat timeout";
  EXPECT_LE(reported_after, 250 * kMs) << "loose bound: timeout 100 ms + status period + a loaded machine";
  // Heartbeat back, enable held: no re-engagement without a new enable edge.
  for (int i = 0; i < 10; ++i) pu.period(true, true);
  EXPECT_EQ(pu.ecu_engaged, 0.0);
  bus.reset();
  EXPECT_EQ(rig.stop(mock), 0);
  const std::string out = rig.output("mock");
  EXPECT_NE(out.find("pu timeouts 1,"), std::string::npos) << out;
}

}  // namespace
