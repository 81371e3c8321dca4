#pragma once
// host.clock_step under `rig chaos`: CLOCK_REALTIME (the vehicle time base) stepped under the rig's
// processes, as an NTP or PTP servo steps a PU's clock, and stepped back by the same amount when the
// fault ends, so the host keeps its time. Each step is a HostChangeRecord before it is made; a
// campaign killed before it stepped back leaves its record, and the next campaign undoes the step
// (sweep). Needs CAP_SYS_TIME (root).
#include <string>
#include <vector>

#include "host_change_record.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::rig {

class ClockStep {
 public:
  // Empty when this process may step the clock, else why not.
  static std::string not_permitted();
  // Steps CLOCK_REALTIME by `step_ns` now, in one step of the kernel (no time lost between a read and
  // a set). Throws std::runtime_error (clock_adjtime refused).
  explicit ClockStep(Nanos step_ns);
  ~ClockStep();  // steps back and removes the record
  ClockStep(const ClockStep&) = delete;
  ClockStep& operator=(const ClockStep&) = delete;

  // Undoes the steps of processes that ended without undoing them; one line per step undone.
  static std::vector<std::string> sweep();

 private:
  Nanos step_ns_;
  HostChangeRecord record_;
};

}  // namespace sensor_rig::rig
