#pragma once
// A camera software-triggered when a LIDAR's sweep crosses the azimuth it looks at. The LIDAR
// driver feeds its sweep samples (timesync::SweepObserver, from its thread); a thread here asks
// timesync::SweepPhase for the next crossing, sleeps until just before it (minus the camera's
// trigger latency) and fires. Afterwards, when the LIDAR's samples cover the crossing, the actual
// crossing is interpolated from them and |exposure start - crossing| is kept (p50/p99/max in the
// camera's /diagnostics). No prediction (LIDAR stopped, not locked yet): no trigger, reported.
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/camera/trigger_group.hpp"
#include "sensor_rig/timesync/sweep_phase.hpp"

namespace sensor_rig::drivers {

struct LidarTriggerFigures {
  timesync::SweepStatus sweep;
  std::uint64_t triggers = 0;        // fired
  std::uint64_t refused = 0;         // a camera refused the trigger (closed, lost)
  std::uint64_t late = 0;            // fired more than 1 ms after the aimed time (woke late)
  std::uint64_t prediction_lost = 0; // times the prediction went away (LIDAR stopped / lost lock)
  std::uint64_t measured = 0;        // triggers whose actual crossing was interpolated
  std::uint64_t unmeasured = 0;      // the LIDAR's samples never covered the crossing (gap, stop)
  bool predicting = false;           // a prediction is available now
  // |exposure start - actual crossing| over the last 1024 measured triggers, and the max ever.
  Nanos error_p50_ns = 0;
  Nanos error_p99_ns = 0;
  Nanos error_max_ns = 0;
};

class LidarTrigger : public TriggerSource, public timesync::SweepObserver {
 public:
  // `camera`: for names and messages. Throws std::invalid_argument for a bad phase config.
  LidarTrigger(std::string camera, LidarTriggerConfig cfg, timesync::SweepPhaseConfig phase = {});
  ~LidarTrigger() override;
  LidarTrigger(const LidarTrigger&) = delete;
  LidarTrigger& operator=(const LidarTrigger&) = delete;

  void add(std::function<bool()> trigger) override;  // before start()
  // realtime_priority > 0: SCHED_FIFO for the trigger thread when permitted (a late wake-up is
  // phase error).
  void start(int realtime_priority = 0);
  void stop();
  [[nodiscard]] Nanos tick_before(Nanos t) const override;
  void observe_sweep(std::span<const timesync::SweepSample> samples) noexcept override;
  void add_status(dds::DriverStatus& s) const override;
  [[nodiscard]] LidarTriggerFigures figures() const;
  [[nodiscard]] const LidarTriggerConfig& config() const noexcept { return cfg_; }

 private:
  struct Pending {
    Nanos target;    // predicted crossing
    Nanos exposure;  // fired + latency
  };
  void run();
  void fire(Nanos target, Nanos aim);
  void settle(Nanos newest) noexcept;  // pending triggers whose crossing the samples now cover
  bool wait_until(Nanos vehicle_ns);    // false when stopped

  std::string camera_;
  LidarTriggerConfig cfg_;
  Nanos latency_ns_;
  std::vector<std::function<bool()>> members_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<Nanos> started_ns_{0};

  mutable std::mutex mutex_;  // everything below: the LIDAR thread, the trigger thread, status()
  timesync::SweepPhase phase_;
  Nanos newest_sample_ns_ = 0;
  std::deque<Pending> pending_;
  RecentTicks recent_exposures_;  // frame stamps
  std::vector<Nanos> errors_;            // ring of |error| (ns), last 1024
  std::size_t errors_next_ = 0;
  LidarTriggerFigures figures_;
};

}  // namespace sensor_rig::drivers
