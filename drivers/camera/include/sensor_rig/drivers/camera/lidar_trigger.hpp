#pragma once
// A camera (or a trigger group: a stereo pair) software-triggered when a LIDAR's sweep crosses the
// azimuth it looks at. The LIDAR driver feeds its sweep samples (timesync::SweepObserver, from its
// thread); a thread here asks timesync::SweepPhase for the next crossing, sleeps until just before
// it (minus the camera's trigger latency) and arms the shot: each member has a firing thread of its
// own that waits for the same instant and calls its camera's trigger, so one camera's GVCP round
// trip never delays another's (a group fires all its members or none). Afterwards, when the
// LIDAR's samples cover the crossing, the actual crossing is interpolated from them and each
// member's phase error is kept: |exposure start − crossing|, the exposure start as the camera
// reports it where its frames say (exposed(): device time mapped or PTP), else its trigger call +
// latency (p50/p99/max in that camera's /diagnostics), with the members' spread (first to last
// trigger call). No prediction (LIDAR stopped, not locked yet): no trigger, reported.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/camera/trigger_group.hpp"
#include "sensor_rig/timesync/sweep_phase.hpp"

namespace sensor_rig::drivers {

class MemberCall;  // a member's call that stop() may leave in flight (src/member_call.hpp)

// p50/p99/max of an ErrorHistory, in ns.
struct ErrorFigure {
  std::uint64_t count = 0;
  Nanos p50_ns = 0;
  Nanos p99_ns = 0;
  Nanos max_ns = 0;
};

// The trigger's figures as one member (camera) sees them: the sweep and the counts of the ticks
// are the group's, `refused`, `measured` and the phase error are the member's own.
struct LidarTriggerFigures {
  timesync::SweepStatus sweep;
  std::uint64_t triggers = 0;        // ticks fired
  std::uint64_t refused = 0;         // this camera refused the trigger (closed, lost)
  // Its call had not returned by the shot's deadline; settled when it returns: refused, or its
  // tick recorded late (a camera that took the trigger exposes for it: the frame is stamped by it).
  std::uint64_t timed_out = 0;
  // Its calls hung past kTriggerCallHungNs, left to their thread (counted refused): the camera is
  // fired afresh from the next shot on.
  std::uint64_t calls_left = 0;
  std::uint64_t late = 0;            // fired more than 1 ms after the aimed time (woke late)
  // Crossings passed unfired: the trigger thread woke more than a quarter turn after them (a frame
  // of every member that never was). Not counted: those of a lost prediction (prediction_lost).
  std::uint64_t skipped = 0;
  std::uint64_t prediction_lost = 0; // times the prediction went away (LIDAR stopped / lost lock)
  std::uint64_t measured = 0;        // this camera's triggers in the phase figure below
  std::uint64_t unmeasured = 0;      // the LIDAR's samples never covered the crossing (gap, stop)
  bool predicting = false;           // a prediction is available now
  // |exposure start - actual crossing| over the last 1024 measured triggers, and the max ever. The
  // exposure start is the camera's own (exposed()) once its frames report one, else the trigger
  // call + latency (`from_device` says which).
  bool from_device = false;
  Nanos error_p50_ns = 0;
  Nanos error_p99_ns = 0;
  Nanos error_max_ns = 0;
  ErrorFigure call_error;            // |trigger call + latency - crossing|: the host's own part
  ErrorFigure to_exposure;           // the camera's exposure start - its trigger call (its own delay)
  std::uint64_t exposure_unmatched = 0;  // reported exposures more than half a turn from their call
  // More than one member: first to last member's trigger call per tick (their stamps differ by it).
  std::size_t members = 0;
  Nanos spread_p50_ns = 0;
  Nanos spread_p99_ns = 0;
  Nanos spread_max_ns = 0;
};

// The crossing a LIDAR trigger fires next: the one after `last_target` (the crossing it fired
// last; 0: none yet), even if already up to a quarter `period` past `hittable` (now + the camera's
// latency: fired at once, late), else the first after `hittable` with the crossings passed counted
// in `skipped`. `crossing_after(t)`: the predicted first crossing after t; none without a
// prediction.
struct NextCrossing {
  std::optional<Nanos> target;
  std::uint64_t skipped = 0;
};
[[nodiscard]] NextCrossing choose_next_crossing(const std::function<std::optional<Nanos>(Nanos)>& crossing_after,
                                                Nanos last_target, Nanos hittable, Nanos period);

class LidarTrigger : public TriggerSource, public timesync::SweepObserver {
 public:
  // `name`: the camera's or the trigger group's, for the threads and messages. Throws
  // std::invalid_argument for a bad phase config.
  LidarTrigger(std::string name, LidarTriggerConfig cfg, timesync::SweepPhaseConfig phase = {});
  ~LidarTrigger() override;
  LidarTrigger(const LidarTrigger&) = delete;
  LidarTrigger& operator=(const LidarTrigger&) = delete;

  std::size_t add(std::function<bool()> trigger) override;  // before start()
  // realtime_priority > 0: SCHED_FIFO for the trigger and firing threads when permitted (a late
  // wake-up is phase error).
  void start(int realtime_priority = 0);
  void stop();  // an armed shot is fired by every member first (at most ~2 ms away)
  // Each member's frames carry its own exposure start (its trigger call + latency). A frame's tick
  // is its latest call at or before `t` (the frame's exposure start as its arrival tells it): a
  // camera may expose sooner after the call than the configured latency, and its frame is then
  // still this call's, not the one a period before (the rig's stereo pair: exposure 80 us after
  // the call at p50 against latency_us 100; 6 of 15 frames matched to the previous tick).
  [[nodiscard]] Nanos tick_before(Nanos t, std::size_t member) const override;
  void exposed(std::size_t member, Nanos tick, Nanos device_exposure_ns) override;
  void observe_sweep(std::span<const timesync::SweepSample> samples) noexcept override;
  void add_status(dds::DriverStatus& s, std::size_t member) const override;
  [[nodiscard]] Nanos first_accepted_since(std::size_t member, Nanos mono) const override;
  [[nodiscard]] LidarTriggerFigures figures(std::size_t member = 0) const;
  [[nodiscard]] const LidarTriggerConfig& config() const noexcept { return cfg_; }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

 private:
  struct Member {
    std::function<bool()> trigger;  // set before start(), called by its firing thread only
    std::shared_ptr<MemberCall> call;  // made by start(), owned with its firing thread
    std::thread thread;             // its firing thread
    // The tick of the call in flight (its call + latency; 0: none), set just before the call: its
    // frame can arrive, and be matched, before the call returns (the camera exposes on the write;
    // its acknowledgement, or a preempted firing thread, comes later). Atomic: no lock between the
    // aim and the call.
    std::unique_ptr<std::atomic<Nanos>> calling = std::make_unique<std::atomic<Nanos>>(0);
    // Under mutex_:
    RecentTicks exposures;          // its frame stamps
    RecentTicks accepted_mono;      // CLOCK_MONOTONIC when its accepted calls were settled
    ErrorHistory device_error;      // |exposure start the camera reported - actual crossing|
    ErrorHistory call_error;        // |trigger call + latency - actual crossing|
    ErrorHistory to_exposure;       // reported exposure start - trigger call
    std::uint64_t refused = 0;
    std::uint64_t timed_out = 0;    // its call had not returned by the shot's deadline (a dead camera)
    std::uint64_t calls_left = 0;
    std::vector<std::shared_ptr<MemberCall>> left_in_flight;  // the trigger thread only
    std::uint64_t unmatched = 0;
  };
  // The shot every firing thread takes: armed by the trigger thread, fired by all members at once.
  struct Shot {
    std::uint64_t generation = 0;   // shots armed so far
    Nanos aim_mono = 0;             // CLOCK_MONOTONIC instant of the calls
    std::vector<Nanos> called;      // per member: vehicle time of its trigger call
    std::vector<char> accepted;     // per member: the camera took the trigger
    std::vector<std::uint64_t> reported;  // per member: the last generation it finished (or skipped)
    std::vector<char> busy;         // per member: still in an older shot's call when this one was armed
    std::vector<char> abandoned;    // per member: the trigger thread stopped waiting for its call
    std::vector<char> taken;        // per member: its firing thread took this shot (calls, not skips)
    std::vector<Nanos> call_began;  // per member: CLOCK_MONOTONIC its call began; 0 when not in one
    bool closing = false;           // stop(): firing threads end once nothing is armed
  };
  // A fired tick, until its crossing is measured and its frames have reported their exposure.
  struct Tick {
    std::uint64_t generation;       // the shot that fired it
    Nanos target;                   // predicted crossing
    std::vector<Nanos> exposures;   // per member: fired + latency; 0 = refused
    std::vector<Nanos> device;      // per member: exposure start the camera reported; 0 = none
    Nanos crossing = 0;             // actual crossing (0: not measured)
    bool settled = false;           // the samples covered it (measured or given up)
  };
  void run();
  void run_member(std::size_t i, std::uint64_t seen, MemberCall& call);  // seen: the shots armed before it started
  void fire(Nanos target, Nanos aim);
  void start_firing_thread(std::size_t i, std::uint64_t seen);
  // shot_mutex_ held: a member's call hung past kTriggerCallHungNs is left, the member gets a fresh
  // firing thread for the next shot.
  void leave_hung_calls(Nanos mono);
  // A member's call that returned after its shot's deadline: refused, or its tick recorded now.
  void settle_late_call(std::size_t i, std::uint64_t generation, Nanos called, bool accepted);
  void settle(Nanos newest) noexcept;  // ticks whose crossing the samples now cover
  void add_device_error(const Tick& t, std::size_t member) noexcept;

  std::string name_;
  LidarTriggerConfig cfg_;
  Nanos latency_ns_;
  std::vector<Member> members_;
  int realtime_priority_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<Nanos> started_ns_{0};

  std::mutex shot_mutex_;  // shot_: the trigger thread and the firing threads
  std::condition_variable shot_cv_;
  Shot shot_;

  mutable std::mutex mutex_;  // everything below: the LIDAR thread, the trigger thread, status()
  timesync::SweepPhase phase_;
  Nanos newest_sample_ns_ = 0;
  std::deque<Tick> ticks_;
  ErrorHistory spread_;           // first to last member's trigger call per tick
  LidarTriggerFigures figures_;   // the group's counts (the members' own are in members_)
};

}  // namespace sensor_rig::drivers
