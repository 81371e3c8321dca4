#include "sensor_rig/common/realtime_thread.hpp"

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/thread_priority.hpp"

namespace sensor_rig {

void make_realtime(std::thread& t, int priority, const std::string& who) {
  if (priority <= 0) return;
  if (const auto r = try_realtime_priority(t.native_handle(), priority); !r)
    log::warn(who, "SCHED_FIFO " + std::to_string(priority) + " refused (" + r.why_not +
                       "), running with normal priority");
}

}  // namespace sensor_rig
