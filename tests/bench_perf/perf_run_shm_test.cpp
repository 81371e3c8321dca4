// Short real runs of `rig perf run --transport shm`: the runner starts and stops its own RouDi
// (ctest RESOURCE_LOCK keeps these from running in parallel with another RouDi user).
#include <filesystem>

#include "perf_run_util.hpp"

namespace sensor_rig::bench::perf::test {
namespace {
namespace fs = std::filesystem;

bool roudi_available() { return fs::exists("/usr/bin/iox-roudi"); }

class PerfRunShm : public ::testing::TestWithParam<std::tuple<int, const char*, const char*, int>> {};

TEST_P(PerfRunShm, CountsAddUpAndRoudiIsCleanedUp) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  if (!roudi_available()) GTEST_SKIP() << "iox-roudi (package iceoryx) not installed";
  const auto [topology, size, message, domain] = GetParam();
  const auto out = fresh_dir("shm_t" + std::to_string(topology) + "_" + message);
  const auto r = rig_perf_run("run --topology " + std::to_string(topology) + " --nodes " + (topology == 1 ? "4" : "3") + " --size " + size +
                                  " --rate 20 --duration 1 --transport shm --message " + message + " --domain " +
                                  std::to_string(domain),
                              out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  check_invariants(r.summary, true);
  EXPECT_EQ(r.summary["transport"], "shm");
  ASSERT_TRUE(r.summary.contains("roudi"));
  if (!r.summary["roudi"]["external"].get<bool>()) {
    // Ours: stopped again, and its shared memory and lock are gone.
    EXPECT_FALSE(fs::exists("/dev/shm/iceoryx_mgmt"));
    EXPECT_FALSE(fs::exists("/tmp/iox-unique-roudi.lock"));
  }
}

INSTANTIATE_TEST_SUITE_P(Topologies, PerfRunShm,
                         ::testing::Values(std::make_tuple(1, "64kB", "fixed", 191), std::make_tuple(2, "1MB", "fixed", 192),
                                           std::make_tuple(3, "16B", "fixed", 193), std::make_tuple(2, "64kB", "seq", 194)));

}  // namespace
}  // namespace sensor_rig::bench::perf::test
