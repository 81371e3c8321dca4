#pragma once
// One member's trigger call on its firing thread (TriggerGroup, LidarTrigger), which the trigger
// source's stop() need not wait for: a camera that died with a software trigger's GVCP write in
// flight holds that call for ~2.4 s (Aravis' retries), and the stop leaves the thread to finish it
// alone (issue 27 item 1). The firing thread owns this object (shared): after a call the source
// left, it returns at once and touches nothing of the source.
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::drivers {

class MemberCall {
 public:
  explicit MemberCall(std::function<bool()> trigger) : trigger_(std::move(trigger)) {}
  // The firing thread: the trigger's answer; nullopt once the source left (before or during the
  // call): the thread ends then, without touching the source.
  std::optional<bool> call();
  // stop(): no call starts from here on; true while one is in flight.
  bool leave();
  // The source gives up on a call hung past its deadline (a camera in GVCP retries) to call the
  // member again on a fresh MemberCall: true, and left, only while a call is in flight; false
  // (nothing changed) when none is.
  bool leave_if_in_call();
  [[nodiscard]] bool in_call() const;

 private:
  std::function<bool()> trigger_;
  mutable std::mutex mutex_;
  bool in_call_ = false;
  bool left_ = false;
};

// A firing thread and its call, as a trigger source keeps them.
struct FiringThread {
  std::thread* thread;
  MemberCall* call;
};

// How long a trigger source's stop() waits for a member's call in flight before it leaves it (a
// healthy call: < 1 ms; a camera that died in a software trigger's GVCP write holds it ~2.4 s).
inline constexpr Nanos kStopGraceNs = 100'000'000;

// stop(), once the firing threads were told to end: each is joined, or detached when its call is
// still in flight `grace_ns` after this began (it finishes alone; the source may go).
void join_or_leave(const std::vector<FiringThread>& threads, Nanos grace_ns = kStopGraceNs);

}  // namespace sensor_rig::drivers
