#pragma once
// When a killed mock's device was really back (host.kill_mock), for the judges of recovery and
// isolation: the rig is measured from there, not from the plan's restart time. A restart 488 ms late
// plus the restarted LIDAR mock's own start (~0.45 s before its first packet) left the rig no time
// for its first scan: "right: host.kill_mock ended at 12.347 s: no complete sample within 1.000 s",
// while the rig published a whole scan 0.1 s after the mock's first packet (whole-rig campaign,
// seed 25, CI of stop 54).
#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

// `planned_end` for any fault but host.kill_mock. For a kill: the later of `planned_end` and the
// real restart (the kill's line in the host's truth, written when the mock was back), and, for a
// device that sends on its own (a LIDAR, the drive-by-wire ECU), its first part on the wire after
// that restart. A camera's frames wait for the rig to reopen it: that time stays the rig's, and the
// restart alone moves its end. A mock that never came back sent nothing: its end stays the restart's
// (or the plan's), and `recovery` breaks.
Nanos back_after(const Input& in, const faults::FaultEvent& e, Nanos planned_end);

}  // namespace sensor_rig::rig::chaos
