#include "sensor_rig/drivers/camera/trigger_group.hpp"

#include <time.h>

#include <algorithm>

#include "member_call.hpp"
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
  Member m;
  m.trigger = std::move(trigger);
  members_.push_back(std::move(m));
  return members_.size() - 1;
}

void TriggerGroup::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  {
    std::lock_guard lock(calls_mutex_);
    closing_ = false;
  }
  for (std::size_t i = 0; i < members_.size(); ++i) start_member(i);
  thread_ = std::thread([this] { run(); });
}

void TriggerGroup::start_member(std::size_t i) {
  Member& m = members_[i];
  m.call = std::make_shared<MemberCall>(m.trigger);
  m.busy = false;
  m.thread = std::thread([this, i, call = m.call] { run_member(i, *call); });
}

void TriggerGroup::leave_hung_call(std::size_t i, Nanos mono) {
  Member& m = members_[i];
  if (!m.busy || mono - m.busy_since <= kTriggerCallHungNs) return;
  std::erase_if(m.left_in_flight, [](const std::shared_ptr<MemberCall>& c) { return !c->in_call(); });
  if (m.left_in_flight.size() >= kMaxTriggerCallsLeft) return;  // its ticks stay skipped, counted
  // Not in its call (it just returned, or its thread has not reached it): the thread clears busy.
  if (!m.call->leave_if_in_call()) return;
  m.left_in_flight.push_back(m.call);
  ++m.left;
  // Left, the thread returns from the call without touching this group: it may outlive it.
  m.thread.detach();
  start_member(i);
}

std::uint64_t TriggerGroup::calls_left(std::size_t member) const {
  std::lock_guard lock(calls_mutex_);
  return member < members_.size() ? members_[member].left : 0;
}

void TriggerGroup::add_status(dds::DriverStatus& s, std::size_t member) const {
  std::lock_guard lock(calls_mutex_);
  if (member >= members_.size()) return;
  s.add_number("trigger_skipped", members_[member].skipped);
  s.add_number("trigger_calls_left", members_[member].left);
}

void TriggerGroup::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  {
    std::lock_guard lock(calls_mutex_);
    closing_ = true;
  }
  calls_cv_.notify_all();
  // A call in flight on a camera that died (its GVCP write in Aravis' retries) is not waited for.
  std::vector<FiringThread> threads;
  for (auto& m : members_)
    if (m.call) threads.push_back({&m.thread, m.call.get()});
  join_or_leave(threads);
}

std::uint64_t TriggerGroup::skipped(std::size_t member) const {
  std::lock_guard lock(calls_mutex_);
  return member < members_.size() ? members_[member].skipped : 0;
}

void TriggerGroup::run_member(std::size_t i, MemberCall& call) {
  std::unique_lock lock(calls_mutex_);
  for (;;) {
    calls_cv_.wait(lock, [&] { return members_[i].pending || closing_; });
    if (!members_[i].pending) return;  // closing, nothing to call
    members_[i].pending = false;
    members_[i].busy = true;
    members_[i].busy_since = monotonic_now_ns();
    lock.unlock();
    // A closed camera refuses: its driver reports that. Left by stop(): this group may be gone.
    if (!call.call()) return;
    lock.lock();
    members_[i].busy = false;
  }
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
    {
      std::lock_guard lock(calls_mutex_);
      const Nanos mono = monotonic_now_ns();
      for (std::size_t i = 0; i < members_.size(); ++i) {
        leave_hung_call(i, mono);
        Member& m = members_[i];
        if (m.busy || m.pending)
          ++m.skipped;  // still in an older tick's call: this one is not queued behind it
        else
          m.pending = true;
      }
    }
    calls_cv_.notify_all();
    ticks_.fetch_add(1);
    next += period;
    if (const Nanos now = monotonic_now_ns(); next < now) next = now;  // late: no burst
  }
}

}  // namespace sensor_rig::drivers
