// LidarTrigger without devices: its config keys, and its thread against a simulated LIDAR whose
// sweep is known exactly (scan batches every 100 ms, as the LIDAR driver delivers them): each
// trigger fires near the true crossing (loose bound: loaded host), once per turn, and stops when
// the samples stop. The mock rig's composed version (real LIDAR driver, GigE fake) is in tests/rig.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/camera/lidar_trigger.hpp"

namespace sensor_rig::drivers {
namespace {

std::string problems_of(const std::string& yaml, CameraConfig* out = nullptr) {
  auto problems = std::make_shared<config::Problems>();
  auto node = config::Node::load_string(yaml, "cams.yaml", problems);
  auto c = parse_camera_config(node);
  if (out != nullptr) *out = c;
  return problems->str();
}

TEST(LidarTriggerConfig, KeysDefaultsAndErrors) {
  CameraConfig c;
  EXPECT_EQ(problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 45, latency_us: 120}\n", &c), "");
  EXPECT_EQ(c.lidar_trigger.lidar, "front");
  EXPECT_DOUBLE_EQ(c.lidar_trigger.azimuth_deg, 45.0);
  EXPECT_DOUBLE_EQ(c.lidar_trigger.latency_us, 120.0);
  EXPECT_EQ(c.source.trigger, camera::TriggerMode::kSoftware);  // implied by lidar:
  EXPECT_TRUE(c.trigger_group.empty());

  std::string p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front}\n");
  EXPECT_NE(p.find("cams.yaml:3:"), std::string::npos) << p;
  EXPECT_NE(p.find("azimuth_deg: required with lidar"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 360}\n");
  EXPECT_NE(p.find("azimuth_deg: must be in [0, 360)"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: -1}\n");
  EXPECT_NE(p.find("azimuth_deg"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 10, mode: line}\n");
  EXPECT_NE(p.find("mode: a LIDAR trigger needs mode: software"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 10, group: stereo}\n");
  EXPECT_NE(p.find("group: a LIDAR-triggered camera is in no trigger group"), std::string::npos) << p;
  p = problems_of("name: c\nbackend: v4l2\ndevice: /dev/video0\ntrigger: {lidar: front, azimuth_deg: 10}\n");
  EXPECT_NE(p.find("trigger modes need the aravis backend"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {mode: software, azimuth_deg: 10}\n");
  EXPECT_NE(p.find("azimuth_deg: only with lidar"), std::string::npos) << p;
}

// The simulated LIDAR: azimuth(t) = 360 * rate * (t - t0) + phase, counter-clockwise or not.
struct Sweep {
  Nanos t0;
  double rate_hz;
  double phase_deg;
  [[nodiscard]] double angle(Nanos t) const { return phase_deg + 360.0 * rate_hz * static_cast<double>(t - t0) * 1e-9; }
  // The crossing of `az` nearest t.
  [[nodiscard]] Nanos crossing_near(double az, Nanos t) const {
    const double k = std::round((angle(t) - az) / 360.0);
    const double target = az + 360.0 * k;
    return t0 + static_cast<Nanos>(std::llround((target - phase_deg) / (360.0 * rate_hz) * 1e9));
  }
};

TEST(LidarTrigger, FiresAtTheSweepCrossingOncePerTurnAndStopsWithTheLidar) {
  LidarTriggerConfig cfg{"front", 45.0, 0.0};
  LidarTrigger trigger("cam", cfg);
  std::mutex m;
  std::vector<Nanos> fired;
  trigger.add([&] {
    std::lock_guard lock(m);
    fired.push_back(vehicle_now_ns());
    return true;
  });
  const Sweep sweep{vehicle_now_ns(), -10.0, 123.0};  // 600 rpm clockwise, as a Velodyne
  std::atomic<bool> lidar_on{true};
  std::thread lidar([&] {
    Nanos covered = sweep.t0;
    while (lidar_on.load()) {
      ::usleep(100'000);  // one scan, delivered when it is complete
      const Nanos now = vehicle_now_ns();
      std::vector<timesync::SweepSample> scan;
      for (Nanos t = covered; t < now; t += 100'000) {
        const double a = std::fmod(std::fmod(sweep.angle(t), 360.0) + 360.0, 360.0);
        scan.push_back({a, t});
      }
      covered = now;
      trigger.observe_sweep(scan);
    }
  });
  trigger.start();
  ::usleep(1'600'000);
  const auto running = trigger.figures();
  lidar_on.store(false);
  lidar.join();
  ::usleep(600'000);  // > the stale time (0.3 s): no prediction, no trigger
  const auto stopped = trigger.figures();
  ::usleep(300'000);
  const auto later = trigger.figures();
  trigger.stop();

  std::vector<Nanos> errors;
  {
    std::lock_guard lock(m);
    for (Nanos f : fired) errors.push_back(std::abs(f - sweep.crossing_near(45.0, f)));
    // Never two triggers for one crossing (a turn is 100 ms).
    for (std::size_t i = 1; i < fired.size(); ++i) EXPECT_GT(fired[i] - fired[i - 1], 50'000'000) << i;
  }
  ASSERT_GE(errors.size(), 5u) << "sweep " << timesync::to_string(running.sweep.state);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 5'000'000) << "median |fire - true crossing| on this host";
  EXPECT_LT(errors.back(), 50'000'000);  // never half a turn off
  EXPECT_EQ(running.sweep.state, timesync::SweepState::kLocked);
  EXPECT_NEAR(running.sweep.rate_hz, -10.0, 0.05);
  EXPECT_GE(running.measured, 3u);  // its own figure, from the samples after each crossing
  EXPECT_LT(running.error_p50_ns, 5'000'000);
  EXPECT_FALSE(stopped.predicting);
  EXPECT_GE(stopped.prediction_lost, 1u);
  EXPECT_EQ(later.triggers, stopped.triggers);
  EXPECT_EQ(later.sweep.state, timesync::SweepState::kStale);
  // Frame stamps: the exposure start of the latest trigger before a frame.
  ASSERT_FALSE(fired.empty());
  EXPECT_NEAR(static_cast<double>(trigger.tick_before(fired.back() + 5'000'000)), static_cast<double>(fired.back()), 2e6);
  dds::DriverStatus st;
  trigger.add_status(st);
  EXPECT_EQ(st.level, dds::Level::kWarn);  // the LIDAR stopped, past the 2 s start-up grace: not triggered
}

}  // namespace
}  // namespace sensor_rig::drivers
