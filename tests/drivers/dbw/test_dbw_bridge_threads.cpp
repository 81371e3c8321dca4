// The bridge node's threads in one process (what ThreadSanitizer watches in `make test-tsan`): the
// DDS reader, the CAN loop and the publisher thread of run_dds_bridge around one BridgeCore, a mock
// ECU on the other end of a socketpair, a 1 kHz DDS command source (10x the bus rate) and a status
// reader. Checks the schedule held the frames to the bus rate and stopping sent neutral frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <string>
#include <thread>

#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"
#include "sensor_rig/drivers/dbw/dds_bridge.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"

namespace dbw = sensor_rig::dbw;
namespace dds = sensor_rig::dds;
namespace msg = sensor_rig::msg;
using sensor_rig::Nanos;

namespace {

TEST(DbwBridgeThreads, FastSourceScheduleAndStopInOneProcess) {
  const int domain = 100 + (::getpid() + 13) % 100;
  const auto protocol = dbw::Protocol::load(dbw::default_protocol_config());
  auto [bridge_end, ecu_end] = dbw::can::make_socketpair();
  dbw::mock::MockEcu ecu(protocol, {});
  dbw::mock::RunOptions mo;
  mo.duration_s = 3.5;
  std::thread ecu_thread([&] { dbw::mock::run_mock(ecu, *ecu_end, mo); });
  sensor_rig::drivers::DdsBridgeOptions bo;
  bo.duration_s = 3.0;
  bo.domain = domain;
  sensor_rig::drivers::DdsBridgeStats stats;
  std::thread bridge_thread([&] { stats = sensor_rig::drivers::run_dds_bridge(protocol, *bridge_end, bo); });

  dds::Participant participant(sensor_rig::drivers::domain_config(domain));
  dds::Topic<msg::DbwCommand> topic(participant, sensor_rig::drivers::kCmdTopic);
  dds::Writer<msg::DbwCommand> writer(participant, topic);
  dds::Topic<msg::DbwStatus> status_topic(participant, sensor_rig::drivers::kStatusTopic);
  dds::Reader<msg::DbwStatus> status(participant, status_topic);
  ASSERT_TRUE(writer.wait_for_readers(1, 3000));
  bool engaged = false;
  msg::DbwCommand c{};
  char frame_id[] = "base_link";
  c.header.frame_id = frame_id;
  const Nanos start = sensor_rig::monotonic_now_ns();
  for (std::uint64_t seq = 1; sensor_rig::monotonic_now_ns() - start < 2'000'000'000; ++seq) {
    const Nanos now = sensor_rig::vehicle_now_ns();
    c.header.stamp = msg::to_time(now);
    c.seq = seq;
    c.enable = seq > 20;
    c.throttle = 0.2;
    writer.write(c, now);
    status.take([&](const msg::DbwStatus& s, const dds_sample_info_t&) { engaged = engaged || s.state == 1; });
    ::usleep(1000);
  }
  bridge_thread.join();
  ecu_thread.join();
  EXPECT_TRUE(engaged);
  EXPECT_GT(stats.commands, 500U);  // ~1 kHz asked; a loaded machine sleeps longer
  EXPECT_GT(stats.commands_deferred, 100U) << "a fast source went out at its own rate";
  // 3 frames per set (steering, longitudinal, heartbeat), at most one set per 8 ms over 3 s + stop.
  EXPECT_LE(stats.frames_sent, 3U * (3000 / 8 + 2 + 3));
  EXPECT_EQ(stats.neutral_sets_on_stop, 3U);
  EXPECT_FALSE(ecu.engaged()) << "the ECU was left engaged after the bridge stopped";
}

}  // namespace
