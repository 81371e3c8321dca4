#pragma once
// SCHED_FIFO for a rig thread (driver, trigger, reader): a thread that wakes late behind a busy
// one adds its delay to every sample. A car's PU grants rtprio; a dev box may refuse it, so the
// answer says whether it worked and why not instead of throwing.
#include <pthread.h>

#include <string>

namespace sensor_rig {

struct PriorityResult {
  bool applied = false;  // the thread now runs SCHED_FIFO at the asked priority
  std::string why_not;   // empty when applied; else e.g. "priority 120 outside 1..99", "Operation not permitted"
  explicit operator bool() const { return applied; }
};

// SCHED_FIFO at `priority` (1..99) for the calling thread.
PriorityResult try_realtime_priority(int priority);
// The same for another thread of this process (e.g. std::thread::native_handle()).
PriorityResult try_realtime_priority(pthread_t thread, int priority);

// The calling thread's policy and priority, for tests and `rig` diagnostics: "SCHED_FIFO 40",
// "SCHED_OTHER 0".
std::string current_scheduling();

}  // namespace sensor_rig
