#pragma once
// Runs `rig perf ...` as a real process and checks the counting invariants of its summary.json.
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
// sent = received + lost per subscriber, categories sum up, latencies in (0, run length), fairness keys.
void check_invariants(const nlohmann::json& s, bool expect_complete);

}  // namespace sensor_rig::bench::perf::test
