// `rig up` with a dbw section: mock Paravan ECU, bridge and command source as separate processes.
// The vehicle model must move under the constant command, and the bridge report ENGAGED; `rig
// monitor` shows the command's stages down to the ECU's status (issue 12).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <utility>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/dds/types.hpp"
#include "rig_process.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig {
namespace {

TEST(DbwRig, CommandSourceDrivesTheMockVehicleThroughTheBridge) {
  test::TempDir dir;
  std::ostringstream y;
  y << "rig:\n  name: e2e-dbw\n  dds: {domain: 19, profile: " << test::source_dir().string()
    << "/config/cyclonedds/loopback.xml}\n"
    << "dbw:\n  protocol: " << test::source_dir().string() << "/config/dbw/paravan_ref.yaml\n  bus: " << (dir.path / "bus.sock").string()
    << "\n  mock_ecu: true\n  command_source: {rate_hz: 50, steer_rad: 0.05, throttle: 0.3, gear: 4}\n";
  const auto cfg = dir.write("rig.yaml", y.str());
  ChildProcess rig({test::rig_bin(), "up", cfg, "--duration", "60"});

  dds::Participant p({19, test::source_dir().string() + "/config/cyclonedds/loopback.xml"});
  dds::QosSpec q;
  q.depth = 200;
  dds::Topic<msg::VehicleState> state_topic(p, "/vehicle/state", q);
  dds::Reader<msg::VehicleState> state(p, state_topic, q);
  dds::Topic<msg::DbwStatus> status_topic(p, "/vehicle/dbw/status", q);
  dds::Reader<msg::DbwStatus> status(p, status_topic, q);
  ASSERT_TRUE(state.wait_for_writers(1, test::kDiscoveryMs)) << "bridge did not come up";
  // The monitor, a separate process, while the vehicle drives (its 3.5 s lie within the loop's 4 s).
  std::pair<int, std::string> monitor;
  std::thread monitor_thread([&] {
    monitor = test::run(test::rig_bin() + " monitor --json --duration 3.5 --domain 19 --dds-profile " +
                        test::source_dir().string() + "/config/cyclonedds/loopback.xml");
  });

  double first_speed = -1, last_speed = -1, last_steer = 0;
  bool engaged = false;
  std::string hash;
  const Nanos until = monotonic_now_ns() + 4'000'000'000;
  while (monotonic_now_ns() < until) {
    state.wait(100);
    state.take([&](const msg::VehicleState& s, const dds_sample_info_t&) {
      if (first_speed < 0) first_speed = s.speed;
      last_speed = s.speed;
      last_steer = s.steering_angle;
    });
    status.take([&](const msg::DbwStatus& s, const dds_sample_info_t&) {
      engaged = engaged || s.state == 1;
      hash = s.config_hash;
    });
  }
  EXPECT_TRUE(engaged);
  EXPECT_EQ(hash.size(), 16u) << "the configuration hash is published";
  EXPECT_GT(last_speed, first_speed + 0.5) << "the vehicle model accelerates under throttle 0.3";
  EXPECT_NEAR(last_steer, 0.05, 0.01) << "steering follows the command";

  // /vehicle/dbw/cmd in the monitor: command stamp -> received (sensor), -> CAN frames written
  // (to_wire), -> the mock ECU's next status frame back on the bus (ecu). The mock sends its status
  // every tx period (10 ms): the ecu stage is measured, > 0 and within the ECU timeout (100 ms).
  monitor_thread.join();
  EXPECT_EQ(monitor.first, 0) << monitor.second;
  nlohmann::json cmd;
  std::istringstream lines(monitor.second);
  for (std::string line; std::getline(lines, line);) {
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_object() && j.value("topic", "") == "/vehicle/dbw/cmd" && j["latency_ms"].contains("ecu")) cmd = j;
  }
  ASSERT_TRUE(cmd.is_object()) << "no ecu stage for /vehicle/dbw/cmd:\n" << monitor.second;
  const auto& ecu = cmd["latency_ms"]["ecu"];
  EXPECT_GT(ecu["p50"].get<double>(), 0.0) << cmd.dump();
  EXPECT_LE(ecu["p50"].get<double>(), ecu["max"].get<double>()) << cmd.dump();
  EXPECT_LT(ecu["max"].get<double>(), 100.0) << cmd.dump();
  for (const char* stage : {"sensor", "to_wire"}) EXPECT_TRUE(cmd["latency_ms"].contains(stage)) << stage << " " << cmd.dump();
  EXPECT_EQ(rig.stop(), 0);
}

}  // namespace
}  // namespace sensor_rig
