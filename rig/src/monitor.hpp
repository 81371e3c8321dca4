#pragma once
// `rig monitor`: discovers the rig's topics, subscribes, and reports per topic and per second the
// rate, size, received, lost and the latency of each stage (SPEC §6):
//   sensor   = first kernel receive - acquisition   (device + wire)
//   assemble = last kernel receive - first           (scan/frame duration on the wire)
//   process  = publish - last kernel receive         (wake-up, decode, assemble)
//   write    = DDS write returned - publish          (serialize and send: on the wire)
//   dds      = subscriber receive - publish          (Cyclone transport)
//   total    = subscriber receive - acquisition
//   to_wire  = DDS write returned - last kernel receive (process + write: the driver's own latency)
//   ecu      = first ECU status frame received - CAN frames written (/vehicle/dbw/cmd only)
// Stages other than dds need the driver's per-sample stamps (rt/rig/stamps); topics published by
// others show dds only. A sample announced by its stamps that does not arrive in time (2 s) is lost.
#include <functional>
#include <string>
#include <vector>

#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::rig {

struct MonitorOptions {
  std::vector<std::string> topics;  // ROS names; empty = every topic with a known type
  double duration_s = 0;            // 0 = until Ctrl-C
  bool json = false;                // one JSON line per topic per second instead of the table
  int period_ms = 1000;
  std::string summary_file;         // when set: whole-run percentiles per topic and stage, as JSON
  std::string record_file;          // when set: one CSV row per stamped sample (sample_record.hpp)
  std::string plot_file;            // when set: at the end, the latency plot of the run (SVG)
  double loss_timeout_s = 2.0;      // a sample announced by its stamps and not received by then is lost
  dds::DomainConfig dds;
  // DDS Security (`--security DIR --identity reader`): to see /vehicle/dbw/cmd when it is protected.
  dds::SecurityConfig security;
  int realtime_priority = 0;        // --rt-priority: SCHED_FIFO for its thread (set by the CLI) and DDS threads
  bool copy_clouds = false;         // hidden --reader copy: deserialize clouds/images (default: views)
  std::function<bool()> keep_going;  // optional: checked every loop; false ends the monitor
};

// Returns the exit code (0 ok).
int run_monitor(const MonitorOptions& options);

}  // namespace sensor_rig::rig
