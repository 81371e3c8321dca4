#pragma once
// host.network_delay on the host's loopback under `rig chaos`, where the kernel has sch_netem (and
// sch_prio): the rig's UDP traffic to the given ports (the LIDARs' data and position ports) held
// back `ms` with `jitter_ms` (netem reorders what its jitter overtakes, as a real network does),
// everything else on `lo` untouched:
//   tc qdisc add dev lo root handle 1: prio bands 3 priomap 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1
//   tc qdisc add dev lo parent 1:3 handle 30: netem delay MSms [JITTERms]
//   tc filter add dev lo parent 1: protocol ip prio 1 u32 match ip protocol 17 0xff match ip dport P 0xffff flowid 1:3
// and when the fault ends `tc filter del dev lo parent 1: prio 1` (new packets pass at once), a wait for
// what netem holds, then `tc qdisc del dev lo root handle 1:`. As host.clock_step, each shaping is a
// HostChangeRecord before it is made; a campaign killed while it stood leaves its record, and the
// next campaign removes the qdisc (sweep). `tc` is $RIG_TC when
// set. Where the kernel has no sch_netem (this CI machine's: CONFIG_NET_SCH_NETEM not set) the LIDAR
// mocks hold their datagrams instead (docs/faults.md "host.network_delay").
#include <string>
#include <vector>

#include "host_change_record.hpp"

namespace sensor_rig::rig {

class LoopbackDelay {
 public:
  // Empty when `lo` can be shaped here (tc runs, lo has no root qdisc of its own, and a prio root
  // with a netem band can be made: probed once per process, and removed), else why not.
  static std::string unavailable();
  // Shapes lo now. Throws std::runtime_error with tc's answer (nothing left behind).
  LoopbackDelay(double ms, double jitter_ms, const std::vector<int>& udp_ports);
  // Removes the filters, lets what netem holds leave (ms + jitter_ms), removes the qdisc and the record.
  ~LoopbackDelay();
  LoopbackDelay(const LoopbackDelay&) = delete;
  LoopbackDelay& operator=(const LoopbackDelay&) = delete;

  // Removes the shaping of processes that ended without removing it; one line per shaping removed.
  static std::vector<std::string> sweep();

 private:
  double hold_ms_;
  HostChangeRecord record_;
};

}  // namespace sensor_rig::rig
