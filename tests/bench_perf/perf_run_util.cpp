#include "perf_run_util.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace sensor_rig::bench::perf::test {
namespace fs = std::filesystem;

std::string rig_bin() {
  const char* b = std::getenv("RIG_BIN");
  if (b == nullptr || !fs::exists(b)) return "";
  return b;
}

std::string fresh_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("rig_perf_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

RigRun rig_perf_run(const std::string& args, const std::string& out) {
  RigRun r;
  r.out = out;
  const std::string cmd = rig_bin() + " perf " + args + " --out " + out + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), buf.size(), p) != nullptr) r.output += buf.data();
  const int st = ::pclose(p);
  r.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream in(fs::path(out) / "summary.json");
  if (in) r.summary = nlohmann::json::parse(in, nullptr, false);
  return r;
}

void check_invariants(const nlohmann::json& s, bool expect_complete) {
  ASSERT_TRUE(s.is_object());
  for (const char* k : {"topology", "nodes", "size", "rate_hz", "transport", "sent", "received", "lost", "sent_on_time",
                        "sent_late", "not_sent", "latency_ms"}) {
    ASSERT_TRUE(s.contains(k)) << "summary.json lacks " << k;
  }
  for (const char* k : {"mean", "p50", "p90", "p99", "max", "std"}) ASSERT_TRUE(s["latency_ms"].contains(k)) << k;
  const auto count = s["count_per_publisher"].get<std::uint64_t>();
  const auto pubs = s["publishers"].get<std::uint64_t>();
  // Publisher categories cover every planned message exactly once.
  EXPECT_EQ(s["sent_on_time"].get<std::uint64_t>() + s["sent_late"].get<std::uint64_t>() + s["not_sent"].get<std::uint64_t>(),
            count * pubs);
  EXPECT_EQ(s["sent"].get<std::uint64_t>(), s["sent_on_time"].get<std::uint64_t>() + s["sent_late"].get<std::uint64_t>());
  // Per subscriber: what its publishers sent = received + lost; in time + late = received.
  std::uint64_t rec = 0, lost = 0;
  for (const auto& sub : s["per_subscriber"]) {
    EXPECT_EQ(sub["expected"].get<std::uint64_t>(), sub["received"].get<std::uint64_t>() + sub["lost"].get<std::uint64_t>());
    EXPECT_EQ(sub["in_time"].get<std::uint64_t>() + sub["late"].get<std::uint64_t>(), sub["received"].get<std::uint64_t>());
    EXPECT_EQ(sub["unexpected"].get<std::uint64_t>(), 0u);
    rec += sub["received"].get<std::uint64_t>();
    lost += sub["lost"].get<std::uint64_t>();
    if (sub["received"].get<std::uint64_t>() > 0) {
      EXPECT_GT(sub["latency_ms"]["mean"].get<double>(), 0.0);
    }
  }
  EXPECT_EQ(rec, s["received"].get<std::uint64_t>());
  EXPECT_EQ(lost, s["lost"].get<std::uint64_t>());
  EXPECT_EQ(rec + lost, s["expected"].get<std::uint64_t>());
  EXPECT_TRUE(s["fairness"].contains("jain_delivery_ratio"));
  // Latencies are positive and shorter than the run.
  const double run_ms = s["duration_s"].get<double>() * 1000.0;
  if (s["received"].get<std::uint64_t>() > 0) {
    EXPECT_GT(s["latency_ms"]["min"].get<double>(), 0.0);
    EXPECT_LT(s["latency_ms"]["max"].get<double>(), run_ms);
    EXPECT_LE(s["latency_ms"]["p50"].get<double>(), s["latency_ms"]["p99"].get<double>());
    EXPECT_LE(s["latency_ms"]["p99"].get<double>(), s["latency_ms"]["max"].get<double>());
  }
  // Every process has resource figures.
  for (const auto& p : s["processes"]) {
    EXPECT_GT(p["pid"].get<int>(), 0);
    EXPECT_GT(p["max_rss_kb"].get<long>(), 0);
  }
  if (expect_complete) {
    EXPECT_TRUE(s["completed"].get<bool>());
    EXPECT_TRUE(s["failed_nodes"].empty()) << s["failed_nodes"].dump();
    // A short run on loopback: everything sent and delivered (reliable QoS).
    EXPECT_EQ(s["sent"].get<std::uint64_t>(), count * pubs);
    EXPECT_EQ(s["lost"].get<std::uint64_t>(), 0u) << s["per_subscriber"].dump();
  }
}

}  // namespace sensor_rig::bench::perf::test
