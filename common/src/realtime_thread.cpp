#include "sensor_rig/common/realtime_thread.hpp"

#include <pthread.h>
#include <sched.h>

#include <cstring>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig {

void make_realtime(std::thread& t, int priority, const std::string& who) {
  if (priority <= 0) return;
  sched_param sp{};
  sp.sched_priority = priority;
  if (const int rc = pthread_setschedparam(t.native_handle(), SCHED_FIFO, &sp); rc != 0)
    log::warn(who, "SCHED_FIFO " + std::to_string(priority) + " refused (" + std::strerror(rc) +
                       "), running with normal priority");
}

}  // namespace sensor_rig
