#include "sensor_rig/common/thread_priority.hpp"

#include <sched.h>

#include <cstring>

namespace sensor_rig {

PriorityResult try_realtime_priority(pthread_t thread, int priority) {
  const int lo = sched_get_priority_min(SCHED_FIFO);
  const int hi = sched_get_priority_max(SCHED_FIFO);
  if (priority < lo || priority > hi)
    return {false, "priority " + std::to_string(priority) + " outside " + std::to_string(lo) + ".." +
                       std::to_string(hi)};
  sched_param sp{};
  sp.sched_priority = priority;
  if (const int rc = pthread_setschedparam(thread, SCHED_FIFO, &sp); rc != 0)
    return {false, std::strerror(rc)};  // EPERM: no root / CAP_SYS_NICE / RLIMIT_RTPRIO
  return {true, {}};
}

PriorityResult try_realtime_priority(int priority) { return try_realtime_priority(pthread_self(), priority); }

std::string current_scheduling() {
  int policy = 0;
  sched_param sp{};
  if (pthread_getschedparam(pthread_self(), &policy, &sp) != 0) return "unknown";
  const char* name = policy == SCHED_FIFO ? "SCHED_FIFO" : policy == SCHED_RR ? "SCHED_RR" : "SCHED_OTHER";
  return std::string(name) + " " + std::to_string(sp.sched_priority);
}

}  // namespace sensor_rig
