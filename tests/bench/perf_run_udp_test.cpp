// Short real runs of `rig perf run` over UDP (loopback): each topology, both UDP transports, the
// LIDAR driver's PointCloud2, a subscriber killed mid-run, and Cyclone's ddsperf floor.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "perf_run_util.hpp"

namespace sensor_rig::bench::perf::test {
namespace {
namespace fs = std::filesystem;

struct Case {
  int topology, nodes;
  const char* size;
  const char* transport;
  const char* message;
  int domain;
  const char* reader = "copy";  // pointcloud2 subscribers: copy | view
};

class PerfRunUdp : public ::testing::TestWithParam<Case> {};

TEST_P(PerfRunUdp, CountsAddUp) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  const Case c = GetParam();
  const auto out = fresh_dir("udp_t" + std::to_string(c.topology) + "_" + c.transport + "_" + c.message + "_" + c.reader);
  const auto r = rig_perf_run("run --topology " + std::to_string(c.topology) + " --nodes " + std::to_string(c.nodes) +
                                  " --size " + c.size + " --rate 20 --duration 1 --transport " + c.transport +
                                  " --message " + c.message + " --domain " + std::to_string(c.domain) +
                                  " --reader " + c.reader,
                              out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  check_invariants(r.summary, true);
  check_raw_csvs(r, true);
  EXPECT_EQ(r.summary["topology"], c.topology);
  EXPECT_EQ(r.summary["transport"], c.transport);
  EXPECT_EQ(r.summary["message"], c.message);
  EXPECT_EQ(r.summary["count_per_publisher"], 20);
  const int pubs = c.topology == 1 ? c.nodes / 2 : c.topology == 2 ? 1 : c.nodes - 1;
  const int subs_total = c.topology == 1 ? c.nodes / 2 : c.topology == 2 ? c.nodes - 1 : c.nodes - 1;  // subscriptions
  EXPECT_EQ(r.summary["publishers"], pubs);
  EXPECT_EQ(r.summary["subscriptions"], subs_total);
  EXPECT_EQ(r.summary["received"].get<int>(), 20 * subs_total);
  // Over UDP nothing is loaned: every write and every take is a copy (a view reads the received
  // serdata, which the network path filled).
  const auto& loans = r.summary["loans"];
  EXPECT_EQ(loans["nodes_reporting"], c.nodes);
  EXPECT_EQ(loans["loaned_writes"], 0);
  EXPECT_EQ(loans["copied_writes"], r.summary["sent"]);
  EXPECT_EQ(loans["zero_copy_takes"], 0);
  EXPECT_EQ(loans["copied_takes"], r.summary["received"]);
  // Raw per-message data kept: one CSV per node.
  int csvs = 0;
  for (const auto& e : fs::directory_iterator(out)) csvs += e.path().extension() == ".csv";
  EXPECT_EQ(csvs, c.nodes);
}

INSTANTIATE_TEST_SUITE_P(Topologies, PerfRunUdp,
                         ::testing::Values(Case{1, 4, "64kB", "udp", "fixed", 181}, Case{2, 4, "16B", "udp", "fixed", 182},
                                           Case{3, 4, "16B", "udp", "fixed", 183}, Case{2, 3, "1MB", "udp-tuned", "fixed", 184},
                                           Case{3, 3, "64kB", "udp-tuned", "fixed", 185},
                                           Case{1, 4, "64kB", "udp-tuned", "fixed", 187},
                                           Case{2, 3, "64kB", "udp", "pointcloud2", 188},
                                           Case{2, 3, "64kB", "udp", "pointcloud2", 178, "view"}));

TEST(PerfRunFault, KilledSubscriberIsReportedAndSummaryWritten) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  const auto out = fresh_dir("udp_kill");
  const auto r = rig_perf_run("run --topology 2 --nodes 4 --size 16B --rate 20 --duration 2 --transport udp "
                              "--domain 186 --fault-kill-subscriber 0.8",
                              out);
  EXPECT_EQ(r.exit_code, 1) << r.output;  // a node failed: runtime failure, but a complete report
  check_invariants(r.summary, false);
  check_raw_csvs(r, false);
  ASSERT_EQ(r.summary["failed_nodes"].size(), 1u) << r.summary.dump(2);
  EXPECT_EQ(r.summary["failed_nodes"][0]["node"], 3);
  EXPECT_NE(r.summary["failed_nodes"][0]["status"].get<std::string>().find("signal 9"), std::string::npos);
  EXPECT_EQ(r.summary["sent"], 40);
  // The survivors got everything; the killed one lost what came after its death, and shows up as
  // the unfair one: lowest delivery ratio, Jain's index below 1.
  double killed_ratio = 1.0;
  for (const auto& sub : r.summary["per_subscriber"]) {
    if (sub["node"] == 3) {
      EXPECT_GT(sub["lost"].get<int>(), 10);
      EXPECT_LT(sub["received"].get<int>(), 40);
      killed_ratio = sub["delivery_ratio"].get<double>();
    } else {
      EXPECT_EQ(sub["received"], 40);
      EXPECT_DOUBLE_EQ(sub["delivery_ratio"].get<double>(), 1.0);
    }
  }
  EXPECT_LT(killed_ratio, 0.75);
  EXPECT_LT(r.summary["fairness"]["jain_delivery_ratio"].get<double>(), 0.99);
  EXPECT_EQ(r.summary["lost"].get<int>(), 40 - r.summary["per_subscriber"][2]["received"].get<int>());
  // The report still renders.
  ASSERT_EQ(std::system((rig_bin() + " perf report " + out + " > /dev/null").c_str()), 0);
  EXPECT_TRUE(fs::exists(fs::path(out) / "report.html"));
  EXPECT_TRUE(fs::exists(fs::path(out) / "report.md"));
}

// Cyclone's ddsperf ping/pong, one size for 2 s: round trips measured, exit 0 (that a size without a
// round trip makes it exit 1 is the unit test PerfDdsperf.UnmeasuredSizesAreNamed).
TEST(PerfDdsperf, MeasuresRoundTrips) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  if (!fs::exists("/usr/bin/ddsperf")) GTEST_SKIP() << "ddsperf not installed (Debian package cyclonedds-tools)";
  const auto out = fresh_dir("ddsperf");
  const auto r = rig_perf_run("ddsperf --transport udp-tuned --size 64kB --rate 20 --duration 2 --domain 189", out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(fs::path(out) / "ddsperf.json");
  const auto j = nlohmann::json::parse(in, nullptr, false);
  ASSERT_TRUE(j.is_object());
  ASSERT_EQ(j["sizes"].size(), 1u);
  EXPECT_EQ(j["sizes"][0]["size"], 65536);
  EXPECT_GT(j["sizes"][0]["roundtrips"].get<int>(), 5);
  EXPECT_GT(j["sizes"][0]["rtt_ms"]["mean"].get<double>(), 0.0);
  EXPECT_LE(j["sizes"][0]["rtt_ms"]["p50"].get<double>(), j["sizes"][0]["rtt_ms"]["max"].get<double>());
  EXPECT_TRUE(j["unmeasured"].empty());
}

}  // namespace
}  // namespace sensor_rig::bench::perf::test
