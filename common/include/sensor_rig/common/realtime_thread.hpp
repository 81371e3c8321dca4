#pragma once
// A node's thread under SCHED_FIFO: a thread that wakes late adds its delay to every sample.
#include <string>
#include <thread>

namespace sensor_rig {

// SCHED_FIFO at `priority` (1..99) for `t`; 0 or less leaves it alone. Refused (no root or
// CAP_SYS_NICE): a warning from `who` ("running with normal priority"), never an error.
void make_realtime(std::thread& t, int priority, const std::string& who);

}  // namespace sensor_rig
