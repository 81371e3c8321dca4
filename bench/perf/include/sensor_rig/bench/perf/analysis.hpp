#pragma once
// Turns the nodes' per-message CSVs and the runner's process outcomes into summary.json (SPEC §7).
// Pure apart from reading the CSV files it is given.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sensor_rig/bench/perf/spec.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::bench::perf {

struct NodeOutcome {
  NodePlan plan;
  int pid = 0;
  std::string csv;           // path of the node's CSV
  std::string stats;         // path of the node's exit stats (JSON: loans, zero-copy takes), may be absent
  bool exited = false;       // reaped
  int exit_code = -1;        // when it exited normally
  int term_signal = 0;       // when a signal ended it
  bool stopped_by_runner = false;  // the runner had to SIGTERM/SIGKILL it after a timeout
  double cpu_s = 0.0;        // user + system, from wait4
  long max_rss_kb = 0;
  [[nodiscard]] bool ok() const { return exited && term_signal == 0 && exit_code == 0 && !stopped_by_runner; }
  [[nodiscard]] std::string status() const;
};

struct RunInput {
  RunSpec spec;
  std::vector<NodeOutcome> nodes;
  Nanos t0_ns = 0;           // common start time
  int domain = 0;
  std::vector<std::string> warnings;
  nlohmann::json extra = nlohmann::json::object();  // merged into the summary (roudi, profile...)
};

nlohmann::json analyse(const RunInput& in);

}  // namespace sensor_rig::bench::perf

namespace sensor_rig::bench::perf {
// One human line for a summary: "T2 N=32 1MB 10Hz shm: sent 600 (on time 600) recv 18600 lost 0 ..."
std::string summary_line(const nlohmann::json& summary);
}  // namespace sensor_rig::bench::perf
