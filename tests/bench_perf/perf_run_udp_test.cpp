// Short real runs of `rig perf run` over UDP (loopback): each topology, both UDP transports, and a
// subscriber killed mid-run.
#include <cstdlib>
#include <filesystem>

#include "perf_run_util.hpp"

namespace sensor_rig::bench::perf::test {
namespace {
namespace fs = std::filesystem;

struct Case {
  int topology, nodes;
  const char* size;
  const char* transport;
  int domain;
};

class PerfRunUdp : public ::testing::TestWithParam<Case> {};

TEST_P(PerfRunUdp, CountsAddUp) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  const Case c = GetParam();
  const auto out = fresh_dir("udp_t" + std::to_string(c.topology) + "_" + c.transport);
  const auto r = rig_perf_run("run --topology " + std::to_string(c.topology) + " --nodes " + std::to_string(c.nodes) +
                                  " --size " + c.size + " --rate 20 --duration 1 --transport " + c.transport +
                                  " --domain " + std::to_string(c.domain),
                              out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  check_invariants(r.summary, true);
  EXPECT_EQ(r.summary["topology"], c.topology);
  EXPECT_EQ(r.summary["transport"], c.transport);
  EXPECT_EQ(r.summary["count_per_publisher"], 20);
  const int pubs = c.topology == 1 ? c.nodes / 2 : c.topology == 2 ? 1 : c.nodes - 1;
  const int subs_total = c.topology == 1 ? c.nodes / 2 : c.topology == 2 ? c.nodes - 1 : c.nodes - 1;  // subscriptions
  EXPECT_EQ(r.summary["publishers"], pubs);
  EXPECT_EQ(r.summary["received"].get<int>(), 20 * subs_total);
  // Raw per-message data kept: one CSV per node.
  int csvs = 0;
  for (const auto& e : fs::directory_iterator(out)) csvs += e.path().extension() == ".csv";
  EXPECT_EQ(csvs, c.nodes);
}

INSTANTIATE_TEST_SUITE_P(Topologies, PerfRunUdp,
                         ::testing::Values(Case{1, 4, "64kB", "udp", 181}, Case{2, 4, "16B", "udp", 182},
                                           Case{3, 4, "16B", "udp", 183}, Case{2, 3, "1MB", "udp-tuned", 184},
                                           Case{3, 3, "64kB", "udp-tuned", 185}));

TEST(PerfRunFault, KilledSubscriberIsReportedAndSummaryWritten) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  const auto out = fresh_dir("udp_kill");
  const auto r = rig_perf_run("run --topology 2 --nodes 4 --size 16B --rate 20 --duration 2 --transport udp "
                              "--domain 186 --fault-kill-subscriber 0.8",
                              out);
  EXPECT_EQ(r.exit_code, 1) << r.output;  // a node failed: runtime failure, but a complete report
  check_invariants(r.summary, false);
  ASSERT_EQ(r.summary["failed_nodes"].size(), 1u) << r.summary.dump(2);
  EXPECT_EQ(r.summary["failed_nodes"][0]["node"], 3);
  EXPECT_NE(r.summary["failed_nodes"][0]["status"].get<std::string>().find("signal 9"), std::string::npos);
  EXPECT_EQ(r.summary["sent"], 40);
  // The survivors got everything; the killed one lost what came after its death.
  for (const auto& sub : r.summary["per_subscriber"]) {
    if (sub["node"] == 3) {
      EXPECT_GT(sub["lost"].get<int>(), 10);
      EXPECT_LT(sub["received"].get<int>(), 40);
    } else {
      EXPECT_EQ(sub["received"], 40);
    }
  }
  EXPECT_EQ(r.summary["lost"].get<int>(), 40 - r.summary["per_subscriber"][2]["received"].get<int>());
  // The report still renders.
  ASSERT_EQ(std::system((rig_bin() + " perf report " + out + " > /dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(fs::path(out) / "report.html"));
  EXPECT_TRUE(fs::exists(fs::path(out) / "report.md"));
}

}  // namespace
}  // namespace sensor_rig::bench::perf::test
