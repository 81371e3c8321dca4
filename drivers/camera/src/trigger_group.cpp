#include "sensor_rig/drivers/camera/trigger_group.hpp"

#include <time.h>

#include <algorithm>

#include "sensor_rig/common/percentile.hpp"

namespace sensor_rig::drivers {

void ErrorHistory::add(Nanos e) {
  if (ring_.size() < kKeep) {
    ring_.push_back(e);
  } else {
    ring_[next_] = e;
    next_ = (next_ + 1) % kKeep;
  }
  ++count_;
  max_ = std::max(max_, e);
}

Nanos ErrorHistory::percentile(double q) const {
  std::vector<double> sorted(ring_.begin(), ring_.end());
  std::sort(sorted.begin(), sorted.end());
  return static_cast<Nanos>(nearest_rank_percentile(sorted, q));
}

TriggerGroup::TriggerGroup(std::string name, double rate_hz) : name_(std::move(name)), rate_hz_(rate_hz) {}

TriggerGroup::~TriggerGroup() { stop(); }

std::size_t TriggerGroup::add(std::function<bool()> trigger) {
  members_.push_back(std::move(trigger));
  return members_.size() - 1;
}

void TriggerGroup::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void TriggerGroup::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

Nanos TriggerGroup::tick_before(Nanos t, std::size_t /*member*/) const {
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
