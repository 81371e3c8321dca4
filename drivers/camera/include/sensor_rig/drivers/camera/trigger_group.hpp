#pragma once
// One software trigger tick for a group of cameras (a stereo pair): a thread that, at the group's
// rate, triggers every member back to back and records the tick's vehicle time, so the frames it
// exposed carry the same stamp.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/driver_status.hpp"

namespace sensor_rig::drivers {

class MemberCall;  // a member's call that stop() may leave in flight (src/member_call.hpp)

// A trigger call still in flight this long is hung (a healthy GVCP write: < 1 ms, ~10 ms on a
// loaded host; one to a camera that rebooted or died: Aravis retries it ~2.4 s). Its shot is lost
// anyway; waiting for it would skip the member's shots to the reopened camera too (issue 27 item 1:
// a reopened stereo camera got no trigger for 2.4 s and was reopened 4 times). Both trigger sources
// leave such a call to its thread and call the member afresh.
inline constexpr Nanos kTriggerCallHungNs = 200'000'000;
// Hung calls left in flight at once per member: more are not started (shots skipped, counted); on
// the same dead connection a fresh call fails at once on the camera's GenICam lock anyway.
inline constexpr std::size_t kMaxTriggerCallsLeft = 2;

// The last ticks (exposure starts) a trigger source fired, for matching a frame to its tick. Not
// synchronized: the source guards it with its own mutex.
class RecentTicks {
 public:
  void add(Nanos tick) {
    // Once: a member's tick is recorded when its call returns and again when its shot closes.
    if (std::find(ticks_.begin(), ticks_.end(), tick) != ticks_.end()) return;
    if (ticks_.size() >= kKeep) ticks_.erase(ticks_.begin());
    ticks_.push_back(tick);
  }
  // The latest tick at or before t; 0 when none.
  [[nodiscard]] Nanos before(Nanos t) const noexcept {
    Nanos best = 0;
    for (Nanos v : ticks_)
      if (v <= t && v > best) best = v;
    return best;
  }
  // The earliest tick at or after t; 0 when none (kept).
  [[nodiscard]] Nanos first_since(Nanos t) const noexcept {
    Nanos best = 0;
    for (Nanos v : ticks_)
      if (v >= t && (best == 0 || v < best)) best = v;
    return best;
  }

 private:
  static constexpr std::size_t kKeep = 16;
  std::vector<Nanos> ticks_;
};

// |error| (or any spread) of the last 1024 events and the largest ever: the trigger figures'
// p50/p99/max. Not synchronized: the owner guards it.
class ErrorHistory {
 public:
  void add(Nanos e);
  [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
  [[nodiscard]] Nanos max() const noexcept { return max_; }
  [[nodiscard]] Nanos percentile(double q) const;  // nearest rank over the kept ones; 0 when none

 private:
  static constexpr std::size_t kKeep = 1024;
  std::vector<Nanos> ring_;
  std::size_t next_ = 0;
  std::uint64_t count_ = 0;
  Nanos max_ = 0;
};

// What fires a software-triggered camera: a periodic group tick (TriggerGroup) or the sweep of a
// LIDAR (LidarTrigger), for one camera or a group (a stereo pair). The camera node registers its
// trigger, gets its member index, and stamps each frame with the exposure start of its latest
// trigger before the frame arrived.
class TriggerSource {
 public:
  virtual ~TriggerSource() = default;
  // Before start(); returns the member index for the calls below (0, 1, ... in order of adding).
  virtual std::size_t add(std::function<bool()> trigger) = 0;
  // Vehicle time of the exposure start of `member`'s latest trigger at or before `t` (0: none yet).
  [[nodiscard]] virtual Nanos tick_before(Nanos t, std::size_t member) const = 0;
  // The frame of `member`'s trigger `tick` (as tick_before gave it) was exposed at
  // `device_exposure_ns`, vehicle time, by the camera's own clock (mapped or PTP): the trigger's
  // figures can then include the camera's own trigger -> exposure delay.
  virtual void exposed(std::size_t /*member*/, Nanos /*tick*/, Nanos /*device_exposure_ns*/) {}
  // The trigger's own figures (for `member`) in that camera's /diagnostics status.
  virtual void add_status(dds::DriverStatus& /*s*/, std::size_t /*member*/) const {}
  // CLOCK_MONOTONIC time of the first trigger `member`'s camera took at or after `mono` (0: none).
  // A triggered camera's watchdog counts from it: a camera whose trigger source stopped (a stopped
  // LIDAR, or one not predicted yet) sends nothing and is reported, not reopened (issue 27 item 2).
  // This default: taken continuously (the watchdog counts from `mono`).
  [[nodiscard]] virtual Nanos first_accepted_since(std::size_t /*member*/, Nanos mono) const { return mono; }
};

class TriggerGroup : public TriggerSource {
 public:
  TriggerGroup(std::string name, double rate_hz);
  ~TriggerGroup() override;
  TriggerGroup(const TriggerGroup&) = delete;
  TriggerGroup& operator=(const TriggerGroup&) = delete;

  std::size_t add(std::function<bool()> trigger) override;  // before start()
  void start();
  void stop();
  // Vehicle time of the latest tick at or before `t` (0: none yet): one for all members.
  [[nodiscard]] Nanos tick_before(Nanos t, std::size_t member) const override;
  [[nodiscard]] std::uint64_t ticks() const noexcept { return ticks_.load(); }
  // Ticks `member` missed because its previous call had not returned (a camera in GVCP timeouts).
  [[nodiscard]] std::uint64_t skipped(std::size_t member) const;
  // Calls of `member` given up on, hung past kTriggerCallHungNs: left to finish on their own thread
  // while the member is called afresh.
  [[nodiscard]] std::uint64_t calls_left(std::size_t member) const;
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  // trigger_skipped, trigger_calls_left.
  void add_status(dds::DriverStatus& s, std::size_t member) const override;


 private:
  // Each member is called on a thread of its own: the tick never waits for a call, so a member
  // whose camera does not answer misses its ticks (counted) and its partners do not (issue 27
  // item 1; they were called one after another). A call hung past kTriggerCallHungNs is left to its
  // thread and the member gets a fresh one.
  struct Member {
    std::function<bool()> trigger;
    std::shared_ptr<MemberCall> call;  // made by start(), owned with its thread
    std::thread thread;
    bool pending = false;  // under calls_mutex_: a tick to call
    bool busy = false;     // in its call
    Nanos busy_since = 0;  // monotonic: when that call began
    std::uint64_t skipped = 0;
    std::uint64_t left = 0;
    std::vector<std::shared_ptr<MemberCall>> left_in_flight;  // pruned once they returned
  };
  void run();
  void run_member(std::size_t i, MemberCall& call);
  void start_member(std::size_t i);                   // its firing thread on a fresh call
  void leave_hung_call(std::size_t i, Nanos mono);   // calls_mutex_ held
  std::string name_;
  double rate_hz_;
  std::vector<Member> members_;
  mutable std::mutex calls_mutex_;  // members_' pending/busy/skipped, closing_
  std::condition_variable calls_cv_;
  bool closing_ = false;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> ticks_{0};
  mutable std::mutex mutex_;
  RecentTicks recent_;
};

}  // namespace sensor_rig::drivers
