#pragma once
// When each fault of a plan ended for its device, for the judges of recovery and isolation (every
// device's and the fused cloud's): one mechanism, the truth read once.
//
// A killed mock (host.kill_mock) ends when its device was really back, not at the plan's restart
// time. A restart 488 ms late plus the restarted LIDAR mock's own start (~0.45 s before its first
// packet) left the rig no time for its first scan: "right: host.kill_mock ended at 12.347 s: no
// complete sample within 1.000 s", while the rig published a whole scan 0.1 s after the mock's first
// packet (whole-rig campaign, seed 25, CI of stop 54).
#include <cstdint>
#include <map>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

// How long after its start a fault keeps its device from delivering, as planned: its duration, a
// killed mock's restart, a stopped mock's pause, a slow open.
double fault_span_s(const faults::FaultEvent& e);

class FaultEnds {
 public:
  explicit FaultEnds(const Input& in);
  // The planned end (start + fault_span_s) for any fault but host.kill_mock. For a kill: the later
  // of that and the real restart (the kill's line in the host's truth, written when the mock was
  // back), and, for a device that sends on its own (a LIDAR, the drive-by-wire ECU), its first part
  // on the wire after that restart. A camera's frames wait for the rig to reopen it: that time stays
  // the rig's, and the restart alone moves its end. A mock that never came back sent nothing: its
  // end stays the restart's (or the plan's), and `recovery` breaks.
  [[nodiscard]] Nanos end(const faults::FaultEvent& e) const;

 private:
  Nanos epoch_vehicle_ns_;
  std::map<std::uint64_t, Nanos> back_;  // host.kill_mock event id -> its device back (vehicle ns)
};

}  // namespace sensor_rig::rig::chaos
