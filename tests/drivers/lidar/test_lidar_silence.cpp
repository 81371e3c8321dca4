// Issue 26, at node level (one process, loopback UDP, real DDS): a LIDAR whose mock is killed and
// restarted (host.kill_mock), twice. A synthetic VLP-16 sends in real time (its clock is vehicle
// time, as the mocks'), falls silent for 0.6 s, then 1.2 s, and each time a new one (counters from
// 0, the rotor 2° behind where the last stopped) takes over. Against the sensors' own truth
// (UnitTracker: the scans they made), every scan made is published or counted lost (`scans_lost`,
// the monitor's count), none more: the silent turns were never made. The old decoder counted the
// 0.6 s silence's turns lost (30 published + 8 lost of 34 made; 73 packets "missing") and dropped
// the restarts' first packets as out of order (their azimuth just behind the last heard); the
// decoder-level cases are test_lidar_stream_gap.
#include <gtest/gtest.h>
#include <time.h>

#include <cmath>
#include <iterator>
#include <string>
#include <vector>

#include "lidar_node_reader.hpp"
#include "rig_process.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/unit_tracker.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

// Sleeps until vehicle time `t` (CLOCK_REALTIME, as the sensors' clocks).
void sleep_until(Nanos t) {
  const timespec ts{static_cast<time_t>(t / 1'000'000'000), static_cast<long>(t % 1'000'000'000)};
  while (::clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, &ts, nullptr) != 0) {
  }
}

std::unique_ptr<lidar::mock::SyntheticSensor> vlp16(Nanos start, double rotor_deg) {
  lidar::mock::SyntheticOptions o;
  o.model = "VLP-16";
  o.start_ns = start;
  o.start_rotor_deg = rotor_deg;
  return lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
}

TEST(LidarSilence, AKilledAndRestartedSensorsSilentTurnsAreNotCountedLost) {
  LidarConfig c;
  c.name = "silence_" + std::to_string(::getpid());
  c.model = "VLP-16";
  c.port = test::free_udp_port();
  c.position_port = test::free_udp_port();
  c.time_source = timesync::TimeSource::kHost;
  c.frame_id = "lidar_" + c.name;
  test::LidarNodeReader<msg::PointCloud2> node(c, "points", 100);
  ASSERT_TRUE(node.start());

  // Killed after 1.05 s of sending, silent 0.6 s (under the old decoders' 1 s time-jump bound) and
  // later 1.2 s (past it), each time restarted as a new sensor; the run ends mid-turn.
  const Nanos t0 = vehicle_now_ns() + 100'000'000;
  struct Silence {
    Nanos from, until;
  };
  const Silence silences[] = {{t0 + 1'050'000'000, t0 + 1'650'000'000}, {t0 + 2'700'000'000, t0 + 3'900'000'000}};
  const Nanos end = t0 + 4'950'000'000;
  auto sensor = vlp16(t0, 0.0);
  lidar::mock::UnitTracker truth(sensor->unit_rule());
  const std::vector<lidar::Endpoint> dest{{"127.0.0.1", static_cast<std::uint16_t>(c.port)}};
  lidar::UdpSender sender(dest);
  std::size_t sent = 0, next_silence = 0;
  double last_rotor_deg = 0.0;
  for (;;) {
    const lidar::mock::SyntheticPacket p = sensor->next();
    if (!p.truth.data) continue;  // position packets: not this test's
    if (p.time_ns >= end) break;
    if (next_silence < std::size(silences) && p.time_ns >= silences[next_silence].from) {  // killed, restarted
      sensor = vlp16(silences[next_silence++].until, std::fmod(last_rotor_deg + 358.0, 360.0));
      truth.restart();
      continue;
    }
    last_rotor_deg = p.truth.rotor_deg;
    (void)truth.add(p.truth, true);
    sleep_until(p.time_ns);
    ASSERT_EQ(sender.send(p.bytes).sent, 1U);
    ++sent;
  }
  ASSERT_TRUE(test::wait_for([&] { return node.status("packets") == std::to_string(sent); }, 30'000))
      << node.status("packets") << " of " << sent;
  std::size_t published = 0;
  ASSERT_TRUE(test::wait_for(
      [&] {
        node.reader.take([&](const msg::PointCloud2&, const dds_sample_info_t&) { ++published; });
        return std::to_string(published) == node.status("scans");
      },
      2000));
  const std::size_t made = truth.closed().size();  // the scans ended before the last packet
  const auto lost = std::stoull(node.status("scans_lost"));
  EXPECT_EQ(published + lost, made) << published << " published + " << lost << " counted lost; the sensors made "
                                    << made;
  EXPECT_EQ(node.status("silences"), "2");
  EXPECT_EQ(node.status("packets_dropped"), "0") << "every packet sent was valid";
  EXPECT_EQ(node.status("missing_packets"), "0") << "none was lost";
}

}  // namespace
}  // namespace sensor_rig::drivers
