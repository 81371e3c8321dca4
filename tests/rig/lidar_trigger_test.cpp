// A camera triggered by a LIDAR's sweep, composed as `rig up` composes it, in one process: a
// synthetic VLP-32C (600 rpm, genuine packets over loopback UDP) -> the real LIDAR driver ->
// its sweep samples -> LidarTrigger (SweepPhase prediction, software trigger) -> a GigE fake camera
// in software trigger mode (one frame per trigger; an in-process fake where no loopback address
// can be added) -> the camera driver. Triggers land near the crossing (measured afterwards from the
// LIDAR's own points), one per turn; when the LIDAR stops, the triggers stop and it is reported.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <optional>
#include <set>
#include <thread>

#include "rig_process.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/camera/camera_driver.hpp"
#include "sensor_rig/drivers/camera/lidar_trigger.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "sensor_rig/lidar/mock/replay.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "status_value.hpp"
#include "test_addresses.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

std::string unique(const std::string& base) { return base + "_" + std::to_string(::getpid()); }

// Plays a synthetic LIDAR to 127.0.0.1:port for `seconds` on its own thread (as `rig lidar replay`).
class SyntheticLidar {
 public:
  SyntheticLidar(const std::string& model, int port, double seconds) {
    lidar::mock::SyntheticOptions o;
    o.model = model;
    o.rpm = 600;
    auto sensor = lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
    constexpr Nanos kLead = 20'000'000;
    sensor->set_start_ns(vehicle_now_ns() + kLead - sensor->first_packet_offset_ns());
    stream_ = std::make_unique<lidar::mock::SyntheticStream>(std::move(sensor));
    dest_ = {{"127.0.0.1", static_cast<std::uint16_t>(port)}};
    sender_ = std::make_unique<lidar::UdpSender>(dest_);
    lidar::mock::ReplayOptions r;
    r.duration_ns = static_cast<Nanos>(seconds * 1e9);
    r.lead_ns = kLead;
    thread_ = std::thread([this, r] { stats_ = lidar::mock::run_replay(*stream_, *sender_, r); });
  }
  ~SyntheticLidar() { join(); }
  void join() {
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::unique_ptr<lidar::mock::SyntheticStream> stream_;
  std::vector<lidar::Endpoint> dest_;
  std::unique_ptr<lidar::UdpSender> sender_;
  lidar::mock::ReplayStats stats_;
  std::thread thread_;
};

// The synthetic VLP-32C's driver config (its clock is the host's).
LidarConfig front_lidar() {
  LidarConfig l;
  l.name = unique("trig_front");
  l.model = "VLP-32C";
  l.port = test::free_udp_port();
  l.time_source = timesync::TimeSource::kSensor;
  l.hour_source = timesync::HourSource::kHost;
  l.min_range_m = 0.5;
  l.frame_id = "lidar_" + l.name;
  return l;
}

// A GigE fake and its address on lo: the fake stops (declared last) before the address goes.
struct GigeMock {
  std::optional<LoopbackAddress> address;
  ChildProcess fake;
};

// A camera triggered by `lidar` at `azimuth_deg`, on a GigE fake at address k of `claim` (which
// gates its stream on the software trigger: one frame per trigger) — started into `mock` — or an
// in-process Aravis fake where no loopback address can be added. Returns whether it is GigE.
bool triggered_camera(CameraConfig& c, const std::string& name, const std::string& lidar, double azimuth_deg,
                      const test::TestAddresses& claim, std::size_t k, GigeMock& mock) {
  c.name = unique(name);
  c.frame_id = "camera_" + c.name;
  c.source.format = camera::PixelFormat::kBayerRG8;
  c.source.width = 320;
  c.source.height = 240;
  c.source.frame_rate = 20;
  c.source.trigger = camera::TriggerMode::kSoftware;
  c.info = camera::uncalibrated(320, 240);
  c.lidar_trigger.lidar = lidar;
  c.lidar_trigger.azimuth_deg = azimuth_deg;
  c.lidar_trigger.latency_us = 100.0;
  const std::string address = claim[k];
  std::string why;
  mock.address = LoopbackAddress::take(address, why);
  const bool gige = mock.address.has_value();
  c.source.device = gige ? address : c.name;
  c.mock.kind = gige ? CameraMockConfig::Kind::kGige : CameraMockConfig::Kind::kAravisInProcess;
  if (!gige) std::fprintf(stderr, "no GigE fake (%s): in-process Aravis fake, frames not gated\n", why.c_str());
  if (gige) {
    camera::mock::GigeFakeOptions fo;
    fo.address = address;
    fo.program = RIG_FAKE_GIGE_CAMERA;  // rig up's GigE mock: exposes on the trigger
    mock.fake = camera::mock::start_gige_fake(fo);
  }
  return gige;
}

// The GigE fake reports each frame's exposure start (its clock, mapped once the mapping locks,
// ~1 s): the phase figure is then the camera's own exposure, which rig-fake-gige-camera starts
// within its 250 us trigger grid (Aravis's own fake: on its 40 ms grid, median ~20 ms). Mapped,
// it carries the mapping's bias (the minimum exposure -> leader delay): 0.6-1.3 ms at load 7-9
// over these few seconds.
void expect_fake_exposures(const LidarTriggerFigures& f, const dds::DriverStatus& st) {
  EXPECT_TRUE(f.from_device);
  EXPECT_EQ(test::status_value(st, "phase_from"), "device_exposure");
  EXPECT_GE(f.to_exposure.count, 3u);
  // A frame more than half a turn after its call (a preempted fake, a reopen) is not the trigger's.
  EXPECT_LE(f.exposure_unmatched, f.to_exposure.count / 4 + 1);
  EXPECT_GT(f.to_exposure.p50_ns, -1'000'000);  // not before the call (within the mapping's error)
  EXPECT_LT(f.to_exposure.p50_ns, 5'000'000) << "p99 " << f.to_exposure.p99_ns;  // grid + mapping bias, not 40 ms
}

TEST(LidarTriggeredCamera, TriggersAtTheSweepCrossingAndStopsWithTheLidar) {
  const LidarConfig l = front_lidar();
  CameraConfig c;
  const auto claim = test::TestAddresses::take(140, 159);
  GigeMock mock;
  const bool gige = triggered_camera(c, "trig_cam", l.name, 45.0, claim, 0, mock);  // a front-left camera

  dds::Participant p;
  dds::StampsWriter stamps(p);
  LidarDriver lidar(l, p, stamps);
  LidarTrigger trigger(c.name, c.lidar_trigger);
  CameraDriver camera(c, p, stamps, &trigger);
  lidar.add_sweep_observer(&trigger);
  lidar.start();
  camera.start();
  trigger.start();
  {
    SyntheticLidar sensor(l.model, l.port, 4.0);
    // GigE: also three frames' own exposure starts, which count only once the camera's clock
    // mapping locked (~1 s of frames; before, its line is the first arrivals').
    const bool measured = wait_for(
        [&] {
          const auto f = trigger.figures();
          return f.call_error.count >= 15 && (!gige || f.to_exposure.count >= 3);
        },
        8000, 20);
    const auto f = trigger.figures();
    const auto cs = camera.status();
    ASSERT_TRUE(measured) << "triggers " << f.triggers << " measured " << f.measured << " unmeasured " << f.unmeasured
                          << " sweep " << timesync::to_string(f.sweep.state) << " samples " << f.sweep.samples
                          << " lidar: " << lidar.status().message << " camera: " << cs.message;
    EXPECT_EQ(f.sweep.state, timesync::SweepState::kLocked);
    EXPECT_NEAR(std::abs(f.sweep.rate_hz), 10.0, 0.1);  // 600 rpm (a Velodyne turns clockwise: negative)
    // Loose bounds for a loaded 2-core host; the p99 goal is the benchmark's (scripts/bench_lidar_trigger.sh).
    EXPECT_LT(f.call_error.p50_ns, 5'000'000) << "p50 " << f.call_error.p50_ns << " p99 " << f.call_error.p99_ns;
    EXPECT_LT(f.call_error.max_ns, 60'000'000);  // never a whole turn off (100 ms)
    EXPECT_GE(f.triggers, f.measured);
    EXPECT_LE(f.unmeasured, f.triggers / 4 + 1);
    EXPECT_EQ(f.refused, 0u);
    EXPECT_EQ(test::status_value(cs, "trigger_lidar"), l.name);
    EXPECT_EQ(test::status_value(cs, "trigger_sweep"), "locked");
    EXPECT_NE(test::status_value(cs, "phase_error_p99_ms"), "<absent>");
    EXPECT_NE(test::status_value(lidar.status(), "sweep_samples"), "0");
    if (gige) {  // one exposure per trigger: the frames came from the triggers
      const auto frames = [&] { return std::strtoull(test::status_value(camera.status(), "frames").c_str(), nullptr, 10); };
      EXPECT_TRUE(wait_for([&] { return frames() >= f.measured / 2; }, 30'000)) << "frames " << frames();
      // Its device clock mapped (locked after ~1 s of frames): stamped with its reported exposure.
      EXPECT_EQ(test::status_value(camera.status(), "stamp_source"), "trigger_exposure");
      expect_fake_exposures(trigger.figures(), camera.status());
    }
    // One trigger per turn (10 Hz), never two for one crossing: count over a second.
    const auto t0 = trigger.figures().triggers;
    ::usleep(1'000'000);
    const auto per_second = trigger.figures().triggers - t0;
    if (trigger.figures().predicting) {
      EXPECT_LE(per_second, 11u);
      EXPECT_GE(per_second, 5u);  // loaded host: a late wake-up skips a crossing, never fires twice
    }
    sensor.join();  // the LIDAR stops sending
  }
  // No samples: no prediction within the stale time (0.3 s), no more triggers, reported.
  ASSERT_TRUE(wait_for([&] { return !trigger.figures().predicting; }, 30'000));
  const auto stopped = trigger.figures().triggers;
  ::usleep(500'000);
  const auto f = trigger.figures();
  EXPECT_EQ(f.triggers, stopped);
  EXPECT_GE(f.prediction_lost, 1u);
  EXPECT_EQ(f.sweep.state, timesync::SweepState::kStale);
  EXPECT_EQ(test::status_value(camera.status(), "trigger_sweep"), "stale");
  trigger.stop();
  camera.stop();
  lidar.stop();
  if (gige) mock.fake.stop(500);
}

// The stereo pair on the front LIDAR (issue 12): one LidarTrigger fires both cameras at once at each
// crossing of azimuth 0; with GigE fakes each trigger is one exposure. The frames of both cameras,
// read over DDS, pair up with stamps within 1 ms; each camera's phase error is measured, from the
// exposure start its frames report.
TEST(LidarTriggeredCamera, StereoPairIsFiredTogetherStampsWithin1msPhaseMeasuredPerCamera) {
  const LidarConfig l = front_lidar();
  CameraConfig cams[2];
  const auto claim = test::TestAddresses::take(160, 199, 2);
  GigeMock fakes[2];
  bool gige = true;
  for (int i = 0; i < 2; ++i) {
    gige = triggered_camera(cams[i], i == 0 ? "trig_left" : "trig_right", l.name, 0.0, claim, i, fakes[i]) && gige;
    cams[i].trigger_group = "stereo";
  }
  dds::Participant p;
  dds::StampsWriter stamps(p);
  LidarDriver lidar(l, p, stamps);
  LidarTrigger trigger("stereo", cams[0].lidar_trigger);
  std::vector<std::unique_ptr<CameraDriver>> drivers;
  std::vector<std::unique_ptr<dds::Topic<msg::Image>>> topics;
  std::vector<std::unique_ptr<dds::Reader<msg::Image>>> readers;
  for (const auto& c : cams) {
    topics.push_back(std::make_unique<dds::Topic<msg::Image>>(p, "/sensors/camera/" + c.name + "/image_raw", c.qos));
    readers.push_back(std::make_unique<dds::Reader<msg::Image>>(p, *topics.back(), c.qos));
    drivers.push_back(std::make_unique<CameraDriver>(c, p, stamps, &trigger));
  }
  lidar.add_sweep_observer(&trigger);
  lidar.start();
  for (auto& d : drivers) d->start();
  trigger.start();
  std::set<Nanos> seen[2];
  {
    SyntheticLidar sensor(l.model, l.port, 4.0);
    const auto take = [&] {
      for (std::size_t i = 0; i < 2; ++i)
        readers[i]->take([&](const msg::Image& m, const dds_sample_info_t&) { seen[i].insert(msg::from_time(m.header.stamp)); });
      return trigger.figures(1).call_error.count >= 12 && seen[0].size() >= 10 && seen[1].size() >= 10;
    };
    const bool ok = wait_for(take, 8000, 20);
    const auto f = trigger.figures(1);
    ASSERT_TRUE(ok) << "triggers " << f.triggers << " measured " << f.measured << " frames " << seen[0].size() << "/"
                    << seen[1].size() << " sweep " << timesync::to_string(f.sweep.state);
  }
  trigger.stop();
  // Every left frame has its right frame within 1 ms (the two trigger calls of one tick, released
  // together: either may come first).
  int paired = 0;
  Nanos worst = 0;
  for (const Nanos t : seen[0]) {
    Nanos nearest = 1'000'000;
    const auto it = seen[1].lower_bound(t);
    if (it != seen[1].end()) nearest = std::min(nearest, *it - t);
    if (it != seen[1].begin()) nearest = std::min(nearest, t - *std::prev(it));
    if (nearest >= 1'000'000) {  // which frame, and how far its partner's nearest stamp was
      const Nanos gap = std::min(it != seen[1].end() ? *it - t : Nanos{1'000'000'000},
                                 it != seen[1].begin() ? t - *std::prev(it) : Nanos{1'000'000'000});
      std::fprintf(stderr, "unpaired left frame %.6f s: nearest right %.3f ms away\n", static_cast<double>(t) * 1e-9,
                   static_cast<double>(gap) * 1e-6);
      continue;
    }
    ++paired;
    worst = std::max(worst, nearest);
  }
  // One frame per trigger (GigE; the in-process fake repeats stamps at its own rate): 5 of 6 left
  // frames pair — no call waits for the other camera's acknowledgement any more, only a preempted
  // firing thread on a loaded host stretches one (was: 3 of 4, the second call after the first's
  // GVCP round trip).
  if (gige) {
    EXPECT_GE(6 * paired, 5 * static_cast<int>(seen[0].size())) << "left " << seen[0].size() << " right " << seen[1].size();
  }
  EXPECT_GE(paired, 8);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto f = trigger.figures(i);
    const auto st = drivers[i]->status();
    EXPECT_GE(f.call_error.count, 10u) << i;
    EXPECT_LT(f.call_error.p50_ns, 5'000'000) << i << " p99 " << f.call_error.p99_ns;  // loose: loaded host
    EXPECT_EQ(f.refused, 0u) << i;
    EXPECT_EQ(test::status_value(st, "trigger_group"), "stereo");
    EXPECT_EQ(test::status_value(st, "phase_measured"), std::to_string(f.measured));
    // GigE fakes (leader at exposure end): the mapped reported exposure; the in-process fake's
    // frames follow its own 25 Hz grid, so its mapped exposure may be far from the tick.
    if (gige) {
      EXPECT_EQ(test::status_value(st, "stamp_source"), "trigger_exposure") << i;
      expect_fake_exposures(f, st);
    }
  }
  const auto f = trigger.figures();
  EXPECT_LT(f.spread_p50_ns, 1'000'000);
  const auto ms = [](Nanos ns) { return static_cast<double>(ns) * 1e-6; };
  const auto left = trigger.figures(0);
  const auto right = trigger.figures(1);
  std::fprintf(stderr,
               "stereo: paired %d of %zu, stamp difference max %.3f ms; trigger spread p50 %.3f p99 %.3f ms; call error "
               "p50 %.3f/%.3f p99 %.3f/%.3f ms; phase (%s) p50 %.3f/%.3f p99 %.3f/%.3f ms; exposures unmatched %llu/%llu of "
               "%llu/%llu\n",
               paired, seen[0].size(), ms(worst), ms(f.spread_p50_ns), ms(f.spread_p99_ns), ms(left.call_error.p50_ns),
               ms(right.call_error.p50_ns), ms(left.call_error.p99_ns), ms(right.call_error.p99_ns),
               left.from_device ? "device exposure" : "trigger call", ms(left.error_p50_ns), ms(right.error_p50_ns),
               ms(left.error_p99_ns), ms(right.error_p99_ns), static_cast<unsigned long long>(left.exposure_unmatched),
               static_cast<unsigned long long>(right.exposure_unmatched),
               static_cast<unsigned long long>(left.to_exposure.count + left.exposure_unmatched),
               static_cast<unsigned long long>(right.to_exposure.count + right.exposure_unmatched));
  for (auto& d : drivers) d->stop();
  lidar.stop();
  for (auto& mock : fakes)
    if (mock.fake.pid() > 0) mock.fake.stop(500);
}

}  // namespace
}  // namespace sensor_rig::drivers
