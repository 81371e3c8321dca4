#pragma once
// Runs one configuration: starts the node processes, waits for discovery, gives them a common start
// time, stops them, and writes DIR/summary.json (SPEC §7) beside the nodes' per-message CSVs.
#include <nlohmann/json.hpp>
#include <string>

#include "sensor_rig/bench/perf/spec.hpp"

namespace sensor_rig::dds {
class RouDi;
}

namespace sensor_rig::bench::perf {

using dds::RouDi;

struct RunOptions {
  std::string profile;            // Cyclone XML; empty: config/cyclonedds/perf-<transport>.xml
  RouDi* roudi = nullptr;         // shm: a RouDi already started by the caller (tables); else own
  bool progress = true;           // one line per second on stderr
  double fault_kill_subscriber_s = -1;  // fault injection: SIGKILL the last subscriber at t0 + s
  int discovery_timeout_s = 0;    // 0: 20 s + 0.5 s per node
};

// Source tree (config files): $RIG_SOURCE_DIR, else the tree this binary was built from.
std::string source_dir();
std::string default_profile(Transport t);
std::string default_roudi_config();

// Returns the summary it wrote. Throws on setup failures (usage errors as cli::UsageError); node
// failures during the run are reported in the summary ("failed_nodes") instead.
nlohmann::json run(const RunSpec& spec, const RunOptions& opt);

}  // namespace sensor_rig::bench::perf
