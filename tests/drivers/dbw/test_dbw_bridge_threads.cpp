// The bridge node's threads in one process (what ThreadSanitizer watches in `make test-tsan`): the
// DDS reader, the CAN loop and the publisher thread of run_dds_bridge around one BridgeCore, a mock
// ECU on the other end of a socketpair, a 1 kHz DDS command source (10x the bus rate) and a status
// reader. Checks the schedule held the frames to the bus rate and stopping sent neutral frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "bridge_outbox.hpp"
#include "dds_domain_lease.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/dbw/dds_bridge.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "wait_bounds.hpp"

namespace dbw = sensor_rig::dbw;
namespace dds = sensor_rig::dds;
namespace msg = sensor_rig::msg;
using sensor_rig::Nanos;

namespace {

using sensor_rig::drivers::AwaitingEcu;
using sensor_rig::drivers::OutboxItem;

OutboxItem written_at(std::uint64_t seq, Nanos written) {
  OutboxItem it;
  it.kind = OutboxItem::Kind::kStamps;
  it.seq = seq;
  it.stamps.written_ns = written;
  return it;
}

// The `ecu` stage's source (issue 12), on synthetic frames: the mock ECU's status, feedback and wheel
// frames classified by BridgeCore, each given a receive stamp of the test's choosing. Only a good
// status frame received after a command's write completes it; a command whose status never comes
// leaves on the timeout with no ECU stamp.
TEST(DbwBridgeEcuStage, FirstGoodStatusAfterTheWriteCompletesTheStamps) {
  const auto protocol = dbw::Protocol::load(dbw::default_protocol_config());
  dbw::BridgeCore core(protocol);
  dbw::mock::MockEcu ecu(protocol, {});
  const Nanos period = protocol.timing().tx_period_ns;
  // One step per ECU period: each gives a status frame (and feedback; wheels every other period).
  std::vector<dbw::can::Frame> status, other;
  for (int i = 0; i < 3; ++i) {
    for (const auto& f : ecu.step(i * period)) {
      const auto kind = core.on_frame({f, i * period}, i * period);
      (kind == dbw::RxKind::kStatus ? status : other).push_back(f);
    }
  }
  ASSERT_EQ(status.size(), 3U);
  ASSERT_GE(other.size(), 3U);
  dbw::BridgeCore bridge(protocol);  // a fresh core: the frames again, in their order, as received
  std::vector<OutboxItem> out;
  const auto push = [&](const OutboxItem& it) { out.push_back(it); };
  AwaitingEcu awaiting;
  const Nanos t0 = 1'000'000'000'000;
  awaiting.on_written(written_at(1, t0 + 1000), push);
  awaiting.on_written(written_at(2, t0 + 5000), push);
  EXPECT_TRUE(out.empty());
  // A feedback frame after both writes answers nothing.
  awaiting.on_frame(bridge, {other[0], t0 + 6000}, 1, push);
  EXPECT_TRUE(out.empty());
  // A status received between the writes completes the first command only.
  EXPECT_EQ(awaiting.on_frame(bridge, {status[0], t0 + 3000}, 2, push), dbw::RxKind::kStatus);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].seq, 1U);
  EXPECT_EQ(out[0].stamps.ecu_status_ns, t0 + 3000);
  // The next status with a broken CRC fails its E2E check: no answer.
  auto bad = status[1];
  bad.data[0] ^= 0x5A;
  EXPECT_EQ(awaiting.on_frame(bridge, {bad, t0 + 7000}, 3, push), dbw::RxKind::kE2eError);
  EXPECT_EQ(out.size(), 1U);
  // The same status intact completes the second one with its own receive time.
  awaiting.on_frame(bridge, {status[1], t0 + 9000}, 4, push);
  ASSERT_EQ(out.size(), 2U);
  EXPECT_EQ(out[1].seq, 2U);
  EXPECT_EQ(out[1].stamps.ecu_status_ns, t0 + 9000);
  EXPECT_EQ(awaiting.size(), 0U);

  // No status back: nothing before the timeout, then the stamps without an ECU time (no stage).
  const Nanos timeout = protocol.timing().ecu_timeout_ns;
  awaiting.on_written(written_at(3, t0 + 20'000), push);
  awaiting.on_frame(bridge, {other[1], t0 + 30'000}, 5, push);
  awaiting.expire(t0 + 20'000 + timeout - 1, timeout, push);
  EXPECT_EQ(out.size(), 2U);
  awaiting.expire(t0 + 20'000 + timeout, timeout, push);
  ASSERT_EQ(out.size(), 3U);
  EXPECT_EQ(out[2].seq, 3U);
  EXPECT_EQ(out[2].stamps.ecu_status_ns, 0);
  // A status received before a command was written does not answer it (written after rx).
  awaiting.on_written(written_at(4, t0 + 50'000), push);
  EXPECT_EQ(awaiting.on_frame(bridge, {status[2], t0 + 50'000}, 6, push), dbw::RxKind::kStatus);
  EXPECT_EQ(out.size(), 3U);
  // Full: the oldest waiting goes out unanswered rather than being overwritten.
  for (std::uint64_t i = 0; i < AwaitingEcu::kCapacity - 1; ++i) awaiting.on_written(written_at(10 + i, t0 + 60'000), push);
  EXPECT_EQ(out.size(), 3U);
  awaiting.on_written(written_at(99, t0 + 70'000), push);
  ASSERT_EQ(out.size(), 4U);
  EXPECT_EQ(out[3].seq, 4U);
  EXPECT_EQ(out[3].stamps.ecu_status_ns, 0);
  awaiting.expire(0, -1, push);  // stopping: every waiting one, unanswered
  EXPECT_EQ(out.size(), 4U + AwaitingEcu::kCapacity);
  EXPECT_EQ(awaiting.size(), 0U);
}

TEST(DbwBridgeThreads, FastSourceScheduleAndStopInOneProcess) {
  const int domain = sensor_rig::test::lease_dds_domain();
  const auto protocol = dbw::Protocol::load(dbw::default_protocol_config());
  auto ends = dbw::can::make_socketpair();  // named, not a structured binding: lambdas capture them
  auto& bridge_end = ends.first;
  auto& ecu_end = ends.second;
  dbw::mock::MockEcu ecu(protocol, {});
  dbw::mock::RunOptions mo;
  // Fixed lifetimes long enough for a loaded host: the writer below stops on a count, not a window
  // (the CI host once managed 322 commands in 2 s); the ECU outlives the bridge to take its neutral sets.
  mo.duration_s = 6.5;
  std::thread ecu_thread([&] { dbw::mock::run_mock(ecu, *ecu_end, mo); });
  sensor_rig::drivers::DdsBridgeOptions bo;
  bo.duration_s = 6.0;
  bo.domain = domain;
  sensor_rig::drivers::DdsBridgeStats stats;
  const Nanos bridge_start = sensor_rig::monotonic_now_ns();
  std::thread bridge_thread([&] { stats = sensor_rig::drivers::run_dds_bridge(protocol, *bridge_end, bo); });

  dds::Participant participant(sensor_rig::drivers::domain_config(domain));
  dds::Topic<msg::DbwCommand> topic(participant, sensor_rig::drivers::kCmdTopic);
  dds::Writer<msg::DbwCommand> writer(participant, topic);
  dds::Topic<msg::DbwStatus> status_topic(participant, sensor_rig::drivers::kStatusTopic);
  dds::Reader<msg::DbwStatus> status(participant, status_topic);
  dds::Topic<msg::SourceStamps> stamps_topic(participant, dds::kStampsTopic, dds::stamps_qos());
  dds::Reader<msg::SourceStamps> stamps(participant, stamps_topic, dds::stamps_qos());
  std::uint64_t stamped = 0, answered = 0, ecu_out_of_range = 0;
  const auto take_stamps = [&] {
    stamps.take([&](const msg::SourceStamps& s, const dds_sample_info_t&) {
      // The commands' stamps (each /vehicle/state sample has its own too).
      if (s.topic == nullptr || std::string_view(s.topic) != sensor_rig::drivers::kCmdTopic) return;
      ++stamped;
      if (s.ecu_status_ns == 0) return;  // no ECU status answered this command (e.g. at stop)
      ++answered;
      // The mock answers every 10 ms; 100 ms is the bridge's ECU timeout.
      if (s.ecu_status_ns <= s.written_ns || s.ecu_status_ns - s.written_ns > 100'000'000) ++ecu_out_of_range;
    });
  };
  ASSERT_TRUE(writer.wait_for_readers(1, sensor_rig::test::kDiscoveryMs));
  bool engaged = false;
  msg::DbwCommand c{};
  char frame_id[] = "base_link";
  c.header.frame_id = frame_id;
  // ~1 kHz until 1500 commands are written, or until 1 s before the bridge stops.
  constexpr std::uint64_t kCommands = 1500;
  const Nanos write_until = bridge_start + 5'000'000'000;
  std::uint64_t written = 0;
  for (std::uint64_t seq = 1; seq <= kCommands && sensor_rig::monotonic_now_ns() < write_until; ++seq) {
    const Nanos now = sensor_rig::vehicle_now_ns();
    c.header.stamp = msg::to_time(now);
    c.seq = seq;
    c.enable = seq > 20;
    c.throttle = 0.2;
    writer.write(c, now);
    ++written;
    status.take([&](const msg::DbwStatus& s, const dds_sample_info_t&) { engaged = engaged || s.state == 1; });
    take_stamps();
    ::usleep(1000);
  }
  bridge_thread.join();
  ecu_thread.join();
  ::usleep(100'000);
  take_stamps();
  // Issue 12: per-command stamps carry the mock ECU's next status frame (the ecu stage), measured.
  // Stamps only for commands put on the bus at once (at 1 kHz most are held for the schedule and
  // go out with the CAN thread's set); the ECU outlives the commands by 1.5 s, so nearly all are
  // answered (a very loaded host may miss the 100 ms ECU timeout for some).
  EXPECT_GT(stamped, 0U);
  EXPECT_GT(answered, 0U);
  EXPECT_GE(answered * 2, stamped) << stamped << " stamped";
  EXPECT_EQ(ecu_out_of_range, 0U);
  EXPECT_TRUE(engaged);
  ASSERT_GT(written, 500U) << "the writer was starved: no fast source to schedule";
  // The bridge's reader keeps the last command only: one woken late on a loaded host takes fewer.
  EXPECT_GE(stats.commands * 2, written) << written << " written";
  EXPECT_GT(stats.commands_deferred, 100U) << "a fast source went out at its own rate";
  // 3 frames per set (steering, longitudinal, heartbeat), at most one set per 8 ms over 6 s + stop.
  EXPECT_LE(stats.frames_sent, 3U * (6000 / 8 + 2 + 3));
  EXPECT_EQ(stats.neutral_sets_on_stop, 3U);
  EXPECT_FALSE(ecu.engaged()) << "the ECU was left engaged after the bridge stopped";
}

}  // namespace
