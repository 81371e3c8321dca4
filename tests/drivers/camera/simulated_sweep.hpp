#pragma once
// A LIDAR sweep known exactly, fed to a LidarTrigger as the LIDAR driver feeds it (a complete scan
// every 100 ms), for the trigger's unit tests.
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "sensor_rig/drivers/camera/lidar_trigger.hpp"

namespace sensor_rig::drivers::sweep_sim {

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

// Feeds `observer` the sweep's samples every 100 ms (a complete scan each) on its own thread.
class SimulatedLidar {
 public:
  SimulatedLidar(const Sweep& sweep, timesync::SweepObserver& observer)
      : thread_([this, sweep, &observer] {
          Nanos covered = sweep.t0;
          while (on_.load()) {
            ::usleep(100'000);  // one scan, delivered when it is complete
            const Nanos now = vehicle_now_ns();
            std::vector<timesync::SweepSample> scan;
            for (Nanos t = covered; t < now; t += 100'000) {
              const double a = std::fmod(std::fmod(sweep.angle(t), 360.0) + 360.0, 360.0);
              scan.push_back({a, t});
            }
            covered = now;
            observer.observe_sweep(scan);
          }
        }) {}
  ~SimulatedLidar() { stop(); }
  SimulatedLidar(const SimulatedLidar&) = delete;
  SimulatedLidar& operator=(const SimulatedLidar&) = delete;
  void stop() {
    on_.store(false);
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> on_{true};
  std::thread thread_;
};

// Runs `trigger` against a simulated 600 rpm sweep until member `watch` has `measured` triggers
// measured (or ~6 s), then lets the sweep run on until every tick fired is measured; false when
// it never got there.
inline bool run_until_measured(LidarTrigger& trigger, std::size_t watch, std::uint64_t measured) {
  const Sweep sweep{vehicle_now_ns(), -10.0, 200.0};
  SimulatedLidar lidar(sweep, trigger);
  trigger.start();
  for (int i = 0; i < 600 && trigger.figures(watch).measured < measured; ++i) ::usleep(10'000);
  trigger.stop();
  ::usleep(250'000);  // the LIDAR's next scans cover the last crossings fired: every tick settled
  lidar.stop();
  return trigger.figures(watch).measured >= measured;
}

}  // namespace sensor_rig::drivers::sweep_sim
