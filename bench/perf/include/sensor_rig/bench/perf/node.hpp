#pragma once
// One load-generator node (a process, started by the runner as `rig perf node ...`).
// Protocol with the runner over the node's stdin/stdout (line based):
//   node -> runner: "READY" once all its writers/readers matched the expected peers (discovery done)
//   runner -> node: "START <t0_ns>"  common start time (CLOCK_REALTIME); publishers pace from it
//   runner -> node: "STOP"           subscribers drain and exit (publishers exit by themselves)
// EOF on stdin means the runner is gone: the node stops as if told STOP.
#include <cstdint>
#include <string>
#include <vector>

#include "sensor_rig/bench/perf/spec.hpp"

namespace sensor_rig::bench::perf {

struct NodeArgs {
  Role role = Role::kPublisher;
  int index = 0;
  std::vector<int> topics;
  int expected_matches = 1;
  std::string run_id;        // makes topic names unique per run: /perf/<run_id>/t<k>
  int domain = 0;
  std::string profile;       // Cyclone XML file
  std::uint32_t size = 0;
  Message message = Message::kFixed;
  ReaderMode reader = ReaderMode::kCopy;  // subscribers of pointcloud2: copy or view
  double rate_hz = 10.0;
  std::uint32_t count = 0;
  int depth = 10;
  bool loan = true;          // publishers: loan samples when Cyclone offers it (shm + fixed type)
  std::string csv;
  std::string stats;         // JSON written at exit: shared memory, loaned/copied writes, zero-copy takes
  int discovery_timeout_ms = 60000;
  int rt_priority = 0;       // > 0: SCHED_FIFO at this priority (inherited by Cyclone's threads)
};

std::string topic_name(const std::string& run_id, int topic);

// Runs the node; returns the process exit code (0 ok, 1 runtime failure).
int run_node(const NodeArgs& args);

}  // namespace sensor_rig::bench::perf
