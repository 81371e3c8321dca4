#include "sensor_rig/dds/thread_scheduling.hpp"

#include <thread>

#include "sensor_rig/common/thread_priority.hpp"

namespace sensor_rig::dds {

std::string realtime_threads_fragment(int priority, std::string* refused) {
  if (priority <= 0) return "";
  // Asked on a throw-away thread: the caller's own scheduling stays as it was.
  PriorityResult probe;
  std::thread([&] { probe = try_realtime_priority(priority); }).join();
  if (!probe) {
    if (refused != nullptr) *refused = probe.why_not;
    return "";
  }
  std::string xml = "<CycloneDDS><Domain Id=\"any\"><Threads>";
  for (const char* name : kRealtimeThreadNames)
    xml += std::string("<Thread name=\"") + name + "\"><Scheduling><Class>realtime</Class><Priority>" +
           std::to_string(priority) + "</Priority></Scheduling></Thread>";
  return xml + "</Threads><Internal><MultipleReceiveThreads>false</MultipleReceiveThreads></Internal></Domain></CycloneDDS>";
}

}  // namespace sensor_rig::dds
