#include "member_call.hpp"

#include <unistd.h>

namespace sensor_rig::drivers {

std::optional<bool> MemberCall::call() {
  {
    std::lock_guard lock(mutex_);
    if (left_) return std::nullopt;
    in_call_ = true;
  }
  const bool accepted = trigger_();
  std::lock_guard lock(mutex_);
  in_call_ = false;
  if (left_) return std::nullopt;
  return accepted;
}

bool MemberCall::leave() {
  std::lock_guard lock(mutex_);
  left_ = true;
  return in_call_;
}

bool MemberCall::leave_if_in_call() {
  std::lock_guard lock(mutex_);
  if (in_call_) left_ = true;
  return in_call_;
}

bool MemberCall::in_call() const {
  std::lock_guard lock(mutex_);
  return in_call_;
}

void join_or_leave(const std::vector<FiringThread>& threads, Nanos grace_ns) {
  bool any = false;
  for (const auto& t : threads) any = t.call->leave() || any;
  // A healthy camera's call ends within a millisecond: waited for, so that the usual stop detaches
  // nothing.
  const Nanos until = monotonic_now_ns() + grace_ns;
  while (any && monotonic_now_ns() < until) {
    ::usleep(1000);
    any = false;
    for (const auto& t : threads) any = any || t.call->in_call();
  }
  for (const auto& t : threads) {
    if (!t.thread->joinable()) continue;
    // No call starts after leave(): one not in flight now never blocks the join.
    if (t.call->in_call())
      t.thread->detach();
    else
      t.thread->join();
  }
}

}  // namespace sensor_rig::drivers
