// The report renders self-contained HTML (SVG, no scripts) with every figure of the paper it rebuilds
// (8, 9, 10, 11, 14), and a markdown table whose paper column states only what the paper stated.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "sensor_rig/bench/perf/records.hpp"
#include "sensor_rig/bench/perf/report.hpp"

namespace sensor_rig::bench::perf {
namespace {
namespace fs = std::filesystem;

// A run directory: summary.json plus one subscriber CSV per subscriber with `lat_ms` latencies.
void make_run(const fs::path& dir, const std::string& label, int topology, int nodes, std::uint32_t size, int subs,
              const std::vector<double>& lat_ms) {
  fs::create_directories(dir);
  nlohmann::json per_sub = nlohmann::json::array();
  for (int k = 0; k < subs; ++k) {
    per_sub.push_back({{"node", k + 1}, {"topics", 1}, {"latency_ms", {{"mean", 0.2 + 0.1 * k}}}});
    std::FILE* f = std::fopen((dir / ("sub_" + std::to_string(k + 1) + ".csv")).c_str(), "w");
    write_sub_header(f);
    for (std::size_t i = 0; i < lat_ms.size(); ++i) {
      const Nanos stamp = 1'000'000'000 + static_cast<Nanos>(i) * 100'000'000;
      write_sub_row(f, {0, static_cast<std::uint32_t>(i), stamp, stamp + static_cast<Nanos>(lat_ms[i] * 1e6)});
    }
    std::fclose(f);
  }
  const auto n = static_cast<int>(lat_ms.size());
  nlohmann::json s = {{"label", label}, {"topology", topology}, {"nodes", nodes}, {"size", size}, {"rate_hz", 10.0},
                      {"transport", "shm"}, {"message", "fixed"}, {"sent", n}, {"received", n * subs}, {"lost", 0},
                      {"sent_on_time", n}, {"sent_late", 0}, {"not_sent", 0}, {"expected", n * subs}, {"loss_pct", 0.0},
                      {"count_per_publisher", n}, {"publishers", 1}, {"subscriptions", subs},
                      {"received_in_time", n * subs}, {"received_late", 0}, {"duration_s", 1.0}, {"t0_ns", 1'000'000'000},
                      {"latency_ms", {{"mean", 0.2}, {"p50", 0.2}, {"p90", 0.3}, {"p99", 0.4}, {"max", 0.5}, {"std", 0.1},
                                      {"min", 0.1}, {"p1", 0.1}, {"p25", 0.15}, {"p75", 0.25}, {"n", n * subs}}},
                      {"per_subscriber", per_sub}, {"fairness", {{"jain_mean_latency", 0.96}}},
                      {"roudi", {{"cpu_s", 0.3}, {"max_rss_kb", 20480}}},
                      {"processes", nlohmann::json::array()}, {"failed_nodes", nlohmann::json::array()}};
  std::ofstream(dir / "summary.json") << s.dump();
}

std::string section(const std::string& html, const std::string& heading) {
  const auto at = html.find(heading);
  if (at == std::string::npos) return "";
  return html.substr(at, html.find("<h2>", at + 1) - at);
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(PerfReport, EveryFigureAndTheTable) {
  const auto dir = fs::temp_directory_path() / ("perf_report_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  // Two sizes x two subscriber counts; the 1 MB runs at 3 and 31 subscribers pool into one 1MB box.
  make_run(dir / "a", "T2 N=32 1MB 10Hz shm", 2, 32, 1048576, 31, {0.5, 0.6, 0.7});
  make_run(dir / "b", "T2 N=4 1MB 10Hz shm", 2, 4, 1048576, 3, {0.4, 0.4});
  make_run(dir / "c", "T2 N=4 64kB 10Hz shm", 2, 4, 65536, 3, {0.1, 0.2});
  const auto r = write_report(dir.string());
  EXPECT_EQ(r.runs, 3);
  std::stringstream html_s, md_s;
  html_s << std::ifstream(r.html).rdbuf();
  md_s << std::ifstream(r.markdown).rdbuf();
  const std::string html = html_s.str(), md = md_s.str();
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("http://cdn"), std::string::npos);

  const auto fig8 = section(html, "(paper Fig. 8)");
  EXPECT_GE(count(fig8, "<circle"), 3u) << "latency over time plots the samples";
  // Fig. 9: one chart (shm, fixed, 10 Hz) with one box per size, the 1 MB box pooling two runs.
  const auto fig9 = section(html, "(paper Fig. 9)");
  EXPECT_EQ(count(fig9, "<svg"), 1u);
  EXPECT_NE(fig9.find("64kB (1 run, 6 msgs)"), std::string::npos) << fig9;
  EXPECT_NE(fig9.find("1MB (2 runs, 99 msgs)"), std::string::npos) << fig9;  // 31 x 3 + 3 x 2
  EXPECT_EQ(count(fig9, "<rect x="), 2u + 1u) << "two boxes plus the frame";
  // Fig. 10: one chart per size, one box per subscriber count.
  const auto fig10 = section(html, "(paper Fig. 10)");
  EXPECT_EQ(count(fig10, "<svg"), 2u);
  EXPECT_NE(fig10.find("shm, fixed, 10 Hz, 1MB"), std::string::npos);
  EXPECT_NE(fig10.find("3 subs (1 run, 6 msgs)"), std::string::npos) << fig10;
  EXPECT_NE(fig10.find("31 subs (1 run, 93 msgs)"), std::string::npos) << fig10;
  // Fig. 11: publisher and subscriber category rows for each run.
  const auto fig11 = section(html, "(paper Fig. 11)");
  EXPECT_EQ(count(fig11, "<svg"), 2u);
  EXPECT_EQ(count(fig11, "T2 N=4 64kB 10Hz shm"), 2u);
  // Fig. 14: a bar per subscriber of the heaviest runs, with Jain's index.
  const auto fig14 = section(html, "(paper Fig. 14)");
  EXPECT_NE(fig14.find("Jain 0.960"), std::string::npos);
  EXPECT_GE(count(fig14, "<svg"), 1u);
  EXPECT_NE(section(html, "<h2>Runs").find("0.3 / 20"), std::string::npos) << "RouDi CPU s / RSS MB";

  // Markdown: one row per run; the paper's figure only where the paper gave one.
  EXPECT_EQ(count(md, "\n| T2 "), 3u) << md;
  const auto row = [&](const std::string& label) {
    const auto at = md.find("| " + label + " |");
    return at == std::string::npos ? std::string() : md.substr(at, md.find('\n', at) - at);
  };
  EXPECT_NE(row("T2 N=32 1MB 10Hz shm").find("Cyclone 15–20 ms mean, Fast DDS 8 ms"), std::string::npos) << md;
  EXPECT_NE(row("T2 N=4 1MB 10Hz shm").find("not all 600 messages of a 60 s run sent on time"), std::string::npos) << md;
  EXPECT_EQ(row("T2 N=4 1MB 10Hz shm").find("15–20"), std::string::npos) << md;
  EXPECT_NE(row("T2 N=4 64kB 10Hz shm").find("| — |"), std::string::npos) << md;
  EXPECT_NE(md.find("loss up to 0.88 %"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sensor_rig::bench::perf
