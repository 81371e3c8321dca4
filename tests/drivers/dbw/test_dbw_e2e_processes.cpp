// End to end across processes: `rig dbw send` (DDS commands) -> `rig dbw bridge` -> unix seqpacket
// bus -> `rig mock paravan` (ECU + vehicle model) -> feedback -> rt/vehicle/state, and the status
// topic with reasons and config hash; the mock's candump log holds both directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "dbw_processes.hpp"
#include "dbw_test_data.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "wait_bounds.hpp"

namespace dbw = sensor_rig::dbw;
namespace msg = sensor_rig::msg;
namespace dds = sensor_rig::dds;

namespace {

TEST(DbwProcesses, CommandsThroughBridgeAndMockEcuComeBackAsVehicleState) {
  dbw::test::RigProcesses rig("dbw_e2e");
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";

  dds::Participant participant(sensor_rig::drivers::domain_config());
  dds::Topic<msg::VehicleState> state_topic(participant, sensor_rig::drivers::kStateTopic);
  dds::Topic<msg::DbwStatus> status_topic(participant, sensor_rig::drivers::kStatusTopic);
  dds::Reader<msg::VehicleState> state_reader(participant, state_topic);
  dds::QosSpec deep;
  deep.depth = 64;
  dds::Reader<msg::DbwStatus> status_reader(participant, status_topic, deep);

  const pid_t mock = rig.start_mock({"--duration", "6"});
  ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
  const pid_t bridge = rig.start("bridge", {"dbw", "bridge", "--transport", rig.bus(), "--duration", "5"});
  ASSERT_TRUE(status_reader.wait_for_writers(1, sensor_rig::test::kDiscoveryMs)) << "bridge status writer not discovered";
  const pid_t send = rig.start("send", {"dbw", "send", "--enable", "--steer", "0.1", "--throttle", "0.4", "--gear", "4",
                                        "--rate", "100", "--duration", "2"});

  double max_speed = 0.0;
  double last_steer = 0.0;
  bool engaged = false;
  bool timeout_reason = false;
  std::string hash;
  const auto end = sensor_rig::monotonic_now_ns() + 4'500'000'000LL;
  while (sensor_rig::monotonic_now_ns() < end) {
    state_reader.wait(50);
    state_reader.take([&](const msg::VehicleState& s, const dds_sample_info_t&) {
      max_speed = std::max(max_speed, s.speed);
      last_steer = s.steering_angle;
    });
    status_reader.take([&](const msg::DbwStatus& s, const dds_sample_info_t&) {
      engaged = engaged || s.state == 1;
      hash = s.config_hash;
      if (std::string(s.event) == "transition" && std::string(s.event_reason) == "command_timeout") timeout_reason = true;
    }, 64);
  }
  EXPECT_EQ(rig.wait_exit(send, 5000), 0);
  EXPECT_EQ(rig.wait_exit(bridge, 5000), 0);
  EXPECT_EQ(rig.wait_exit(mock, 5000), 0);
  EXPECT_TRUE(engaged);
  EXPECT_TRUE(timeout_reason) << "no command_timeout transition after the source stopped";
  EXPECT_EQ(hash.size(), 16U);
  EXPECT_GT(max_speed, 0.8) << "vehicle did not move";
  EXPECT_NEAR(last_steer, 0.1, 0.01);

  // The mock's bus log: both directions, the PU's steering request enabled then neutral.
  std::ifstream in(rig.bus_log());
  dbw::can::CandumpReader reader(in);
  dbw::can::LogRecord rec;
  int pu_enabled = 0, pu_neutral_after = 0, ecu_frames = 0;
  while (reader.next(rec)) {
    if (rec.frame.id == 0x100) {
      const bool en = (rec.frame.data[1] & 0x10) != 0;
      if (en) ++pu_enabled;
      if (!en && pu_enabled > 0) ++pu_neutral_after;
    }
    if (rec.frame.id == 0x180) ++ecu_frames;
  }
  EXPECT_EQ(reader.malformed(), 0U);
  EXPECT_GT(pu_enabled, 150);
  EXPECT_GT(pu_neutral_after, 10);
  EXPECT_GT(ecu_frames, 300);
}

}  // namespace
