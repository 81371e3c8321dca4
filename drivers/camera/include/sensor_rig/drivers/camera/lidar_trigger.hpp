#pragma once
// A camera (or a trigger group: a stereo pair) software-triggered when a LIDAR's sweep crosses the
// azimuth it looks at. The LIDAR driver feeds its sweep samples (timesync::SweepObserver, from its
// thread); a thread here asks timesync::SweepPhase for the next crossing, sleeps until just before
// it (minus the camera's trigger latency) and fires every member back to back. Afterwards, when
// the LIDAR's samples cover the crossing, the actual crossing is interpolated from them and each
// member's |exposure start - crossing| is kept (p50/p99/max in that camera's /diagnostics), with
// the members' spread (first to last trigger call). No prediction (LIDAR stopped, not locked
// yet): no trigger, reported.
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

// The trigger's figures as one member (camera) sees them: the sweep and the counts of the ticks
// are the group's, `refused`, `measured` and the phase error are the member's own.
struct LidarTriggerFigures {
  timesync::SweepStatus sweep;
  std::uint64_t triggers = 0;        // ticks fired
  std::uint64_t refused = 0;         // this camera refused the trigger (closed, lost)
  std::uint64_t late = 0;            // fired more than 1 ms after the aimed time (woke late)
  std::uint64_t prediction_lost = 0; // times the prediction went away (LIDAR stopped / lost lock)
  std::uint64_t measured = 0;        // this camera's triggers whose actual crossing was interpolated
  std::uint64_t unmeasured = 0;      // the LIDAR's samples never covered the crossing (gap, stop)
  bool predicting = false;           // a prediction is available now
  // |exposure start - actual crossing| over the last 1024 measured triggers, and the max ever.
  Nanos error_p50_ns = 0;
  Nanos error_p99_ns = 0;
  Nanos error_max_ns = 0;
  // More than one member: first to last member's trigger call per tick (their stamps differ by it).
  std::size_t members = 0;
  Nanos spread_p50_ns = 0;
  Nanos spread_p99_ns = 0;
  Nanos spread_max_ns = 0;
};

class LidarTrigger : public TriggerSource, public timesync::SweepObserver {
 public:
  // `name`: the camera's or the trigger group's, for the thread and messages. Throws
  // std::invalid_argument for a bad phase config.
  LidarTrigger(std::string name, LidarTriggerConfig cfg, timesync::SweepPhaseConfig phase = {});
  ~LidarTrigger() override;
  LidarTrigger(const LidarTrigger&) = delete;
  LidarTrigger& operator=(const LidarTrigger&) = delete;

  std::size_t add(std::function<bool()> trigger) override;  // before start()
  // realtime_priority > 0: SCHED_FIFO for the trigger thread when permitted (a late wake-up is
  // phase error).
  void start(int realtime_priority = 0);
  void stop();
  // Each member's frames carry its own exposure start (its trigger call + latency).
  [[nodiscard]] Nanos tick_before(Nanos t, std::size_t member) const override;
  void observe_sweep(std::span<const timesync::SweepSample> samples) noexcept override;
  void add_status(dds::DriverStatus& s, std::size_t member) const override;
  [[nodiscard]] LidarTriggerFigures figures(std::size_t member = 0) const;
  [[nodiscard]] const LidarTriggerConfig& config() const noexcept { return cfg_; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

 private:
  struct Member {
    std::function<bool()> trigger;  // set before start(), called by the trigger thread only
    // Under mutex_:
    RecentTicks exposures;          // its frame stamps
    ErrorHistory phase_error;       // |exposure start - actual crossing|
    std::uint64_t refused = 0;
  };
  struct Pending {
    Nanos target;                   // predicted crossing
    std::vector<Nanos> exposures;   // per member: fired + latency; 0 = refused
  };
  void run();
  void fire(Nanos target, Nanos aim);
  void settle(Nanos newest) noexcept;  // pending triggers whose crossing the samples now cover
  bool wait_until(Nanos vehicle_ns);    // false when stopped

  std::string name_;
  LidarTriggerConfig cfg_;
  Nanos latency_ns_;
  std::vector<Member> members_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<Nanos> started_ns_{0};

  mutable std::mutex mutex_;  // everything below: the LIDAR thread, the trigger thread, status()
  timesync::SweepPhase phase_;
  Nanos newest_sample_ns_ = 0;
  std::deque<Pending> pending_;
  ErrorHistory spread_;           // first to last member's trigger call per tick
  LidarTriggerFigures figures_;   // the group's counts (the members' own are in members_)
};

}  // namespace sensor_rig::drivers
