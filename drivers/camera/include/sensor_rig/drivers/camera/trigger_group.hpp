#pragma once
// One software trigger tick for a group of cameras (a stereo pair): a thread that, at the group's
// rate, triggers every member back to back and records the tick's vehicle time, so the frames it
// exposed carry the same stamp.
#include <atomic>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/driver_status.hpp"

namespace sensor_rig::drivers {

// The last ticks (exposure starts) a trigger source fired, for matching a frame to its tick. Not
// synchronized: the source guards it with its own mutex.
class RecentTicks {
 public:
  void add(Nanos tick) {
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

 private:
  static constexpr std::size_t kKeep = 16;
  std::vector<Nanos> ticks_;
};

// What fires a software-triggered camera: a periodic group tick (TriggerGroup) or the sweep of a
// LIDAR (LidarTrigger). The camera node registers its trigger and stamps each frame with the
// exposure start of the latest trigger before the frame arrived.
class TriggerSource {
 public:
  virtual ~TriggerSource() = default;
  virtual void add(std::function<bool()> trigger) = 0;  // before start()
  // Vehicle time of the exposure start of the latest trigger at or before `t` (0: none yet).
  [[nodiscard]] virtual Nanos tick_before(Nanos t) const = 0;
  // The trigger's own figures in the camera's /diagnostics status.
  virtual void add_status(dds::DriverStatus& /*s*/) const {}
};

class TriggerGroup : public TriggerSource {
 public:
  TriggerGroup(std::string name, double rate_hz);
  ~TriggerGroup() override;
  TriggerGroup(const TriggerGroup&) = delete;
  TriggerGroup& operator=(const TriggerGroup&) = delete;

  void add(std::function<bool()> trigger) override;  // before start()
  void start();
  void stop();
  // Vehicle time of the latest tick at or before `t` (0: none yet).
  [[nodiscard]] Nanos tick_before(Nanos t) const override;
  [[nodiscard]] std::uint64_t ticks() const noexcept { return ticks_.load(); }
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

 private:
  void run();
  std::string name_;
  double rate_hz_;
  std::vector<std::function<bool()>> members_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> ticks_{0};
  mutable std::mutex mutex_;
  RecentTicks recent_;
};

}  // namespace sensor_rig::drivers
