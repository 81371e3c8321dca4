#include "sensor_rig/drivers/camera/trigger_group.hpp"

#include <time.h>

namespace sensor_rig::drivers {

TriggerGroup::TriggerGroup(std::string name, double rate_hz) : name_(std::move(name)), rate_hz_(rate_hz) {}

TriggerGroup::~TriggerGroup() { stop(); }

void TriggerGroup::add(std::function<bool()> trigger) { members_.push_back(std::move(trigger)); }

void TriggerGroup::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void TriggerGroup::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

Nanos TriggerGroup::tick_before(Nanos t) const {
  std::lock_guard lock(mutex_);
  return recent_.before(t);
}

void TriggerGroup::run() {
  const Nanos period = static_cast<Nanos>(1e9 / rate_hz_);
  Nanos next = monotonic_now_ns();
  while (!stop_.load()) {
    const timespec ts{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    if (stop_.load()) break;
    const Nanos tick = vehicle_now_ns();
    {
      std::lock_guard lock(mutex_);
      recent_.add(tick);
    }
    for (auto& m : members_) (void)m();  // a closed camera refuses: its driver reports that
    ticks_.fetch_add(1);
    next += period;
    if (const Nanos now = monotonic_now_ns(); next < now) next = now;  // late: no burst
  }
}

}  // namespace sensor_rig::drivers
