#pragma once
// Runs `rig perf ...` as a real process and checks the counting invariants of its summary.json,
// and re-counts the raw per-message CSVs independently of the runner's analysis.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

namespace sensor_rig::bench::perf::test {

struct RigRun {
  int exit_code = -1;
  nlohmann::json summary;
  std::string out;
  std::string output;  // stdout + stderr
};

// Empty when RIG_BIN is not set/present (the caller skips).
std::string rig_bin();
std::string fresh_dir(const std::string& name);
RigRun rig_perf_run(const std::string& args, const std::string& out);
// sent = received + lost per subscriber, categories sum up, latencies in (0, run length), fairness
// (mean ranks in [0, 1], Jain's index recomputed from the per-subscriber ratios, 1 without loss);
// with expect_complete every subscriber got exactly what its publishers sent.
void check_invariants(const nlohmann::json& s, bool expect_complete);
// Reads pub_*.csv / sub_*.csv itself: distinct (topic, seq) rows per subscriber against the rows its
// publishers marked sent; duplicates and ids never sent must match what the summary reports.
// With expect_complete: every subscriber holds every id its publishers sent, and nothing else.
void check_raw_csvs(const RigRun& r, bool expect_complete);

}  // namespace sensor_rig::bench::perf::test
