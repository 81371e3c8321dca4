#pragma once
// `rig perf table1|table2`: the paper's parameter grids, one run per cell, with progress and ETA.
#include <string>
#include <vector>

#include "sensor_rig/bench/perf/spec.hpp"

namespace sensor_rig::bench::perf {

struct GridOptions {
  int table = 1;
  double duration_s = 60.0;
  Transport transport = Transport::kShm;
  Message message = Message::kFixed;
  std::string out;
  std::vector<int> topologies;          // filters; empty = all
  std::vector<int> nodes;
  std::vector<std::string> sizes;
  std::vector<double> rates;
  int domain = -1;
  int rt_priority = 0;
  bool no_report = false;
};

// The cells of a table after filters (pure). With 2 nodes the three topologies coincide: one run.
std::vector<RunSpec> grid_specs(const GridOptions& g);
// Runs them (one RouDi for the whole grid with shm), then writes the report. Returns an exit code.
int run_grid(const GridOptions& g);

}  // namespace sensor_rig::bench::perf
