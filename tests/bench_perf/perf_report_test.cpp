// The report renders self-contained HTML (SVG, no scripts) and a markdown table with the paper's figures.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>
#include <sstream>

#include "sensor_rig/bench/perf/report.hpp"

namespace sensor_rig::bench::perf {
namespace {
namespace fs = std::filesystem;

TEST(PerfReport, RendersRunsFoundBelowDir) {
  const auto dir = fs::temp_directory_path() / ("perf_report_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "T2_N32_1MB");
  nlohmann::json s = {{"label", "T2 N=32 1MB 10Hz shm"}, {"topology", 2}, {"nodes", 32}, {"size", 1048576},
                      {"rate_hz", 10.0}, {"transport", "shm"}, {"sent", 10}, {"received", 20}, {"lost", 0},
                      {"sent_on_time", 10}, {"sent_late", 0}, {"not_sent", 0}, {"expected", 20}, {"loss_pct", 0.0},
                      {"count_per_publisher", 10}, {"publishers", 1}, {"received_in_time", 20}, {"received_late", 0},
                      {"duration_s", 1.0}, {"t0_ns", 1000},
                      {"latency_ms", {{"mean", 0.2}, {"p50", 0.2}, {"p90", 0.3}, {"p99", 0.4}, {"max", 0.5}, {"std", 0.1},
                                      {"min", 0.1}, {"p1", 0.1}, {"p25", 0.15}, {"p75", 0.25}, {"n", 20}}},
                      {"per_subscriber", {{{"node", 1}, {"latency_ms", {{"mean", 0.2}}}}, {{"node", 2}, {"latency_ms", {{"mean", 0.3}}}}}},
                      {"fairness", {{"jain_mean_latency", 0.96}}}, {"processes", nlohmann::json::array()},
                      {"failed_nodes", nlohmann::json::array()}};
  std::ofstream(dir / "T2_N32_1MB" / "summary.json") << s.dump();
  std::ofstream(dir / "T2_N32_1MB" / "sub_1.csv") << "topic,seq,stamp_ns,recv_ns\n0,0,1000,201000\n";
  const auto r = write_report(dir.string());
  EXPECT_EQ(r.runs, 1);
  std::stringstream html, md;
  html << std::ifstream(r.html).rdbuf();
  md << std::ifstream(r.markdown).rdbuf();
  EXPECT_NE(html.str().find("<svg"), std::string::npos);
  EXPECT_EQ(html.str().find("<script"), std::string::npos);
  EXPECT_EQ(html.str().find("http://cdn"), std::string::npos);
  EXPECT_NE(html.str().find("Fig. 8"), std::string::npos);
  EXPECT_NE(html.str().find("Fig. 14"), std::string::npos);
  EXPECT_NE(md.str().find("T2 N=32 1MB 10Hz shm"), std::string::npos);
  EXPECT_NE(md.str().find("15-20 ms"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sensor_rig::bench::perf
