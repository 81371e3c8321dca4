#include "perf_run_util.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace sensor_rig::bench::perf::test {
namespace fs = std::filesystem;

std::string rig_bin() {
  const char* b = std::getenv("RIG_BIN");
  if (b == nullptr || !fs::exists(b)) return "";
  return b;
}

std::string fresh_dir(const std::string& name) {
  // One folder for the test process, removed when it ends (a failed test's runs too).
  static const struct ProcessDir {
    fs::path path = fs::temp_directory_path() / ("rig_perf_test_" + std::to_string(::getpid()));
    ~ProcessDir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } process_dir;
  const auto d = process_dir.path / name;
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
  // Fairness (paper Fig. 14): ranks are normalised positions, Jain's index follows from the ratios.
  double sum = 0, sum_sq = 0;
  for (const auto& sub : s["per_subscriber"]) {
    const auto e = sub["expected"].get<double>();
    const double ratio = e > 0 ? sub["received"].get<double>() / e : 1.0;
    EXPECT_DOUBLE_EQ(sub["delivery_ratio"].get<double>(), ratio);
    sum += ratio;
    sum_sq += ratio * ratio;
    if (sub.contains("mean_rank")) {
      EXPECT_GE(sub["mean_rank"].get<double>(), 0.0);
      EXPECT_LE(sub["mean_rank"].get<double>(), 1.0);
    }
  }
  const auto n_subs = static_cast<double>(s["per_subscriber"].size());
  ASSERT_TRUE(s["fairness"].contains("jain_delivery_ratio"));
  if (n_subs > 0) {
    EXPECT_NEAR(s["fairness"]["jain_delivery_ratio"].get<double>(), sum * sum / (n_subs * sum_sq), 1e-12);
  }
  if (lost == 0) {
    EXPECT_DOUBLE_EQ(s["fairness"]["jain_delivery_ratio"].get<double>(), 1.0);
  }
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
    for (const char* k : {"duplicates", "never_sent", "unexpected", "stamp_mismatch"}) {
      EXPECT_EQ(s[k].get<std::uint64_t>(), 0u) << k;
    }
    // Every subscription got every message its publisher sent: topology 2 fans one publisher out to
    // N-1 subscribers; in topologies 1 and 3 each topic has one reader.
    const auto per_topic = s["topology"].get<int>() == 2 ? s["nodes"].get<std::uint64_t>() - 1 : 1u;
    EXPECT_EQ(s["received"].get<std::uint64_t>(), s["sent"].get<std::uint64_t>() * per_topic);
    for (const auto& sub : s["per_subscriber"]) EXPECT_EQ(sub["received"], sub["expected"]);
    // Every copy of a message reaches all of its k subscribers: ranks 0, 1/(k-1), ..., 1 each time,
    // so the subscribers' mean ranks average exactly 1/2.
    if (per_topic >= 2) {
      double rank_sum = 0;
      for (const auto& sub : s["per_subscriber"]) {
        ASSERT_TRUE(sub.contains("mean_rank")) << sub.dump();
        rank_sum += sub["mean_rank"].get<double>();
      }
      EXPECT_NEAR(rank_sum / n_subs, 0.5, 1e-9);
    }
  }
}

namespace {
// Rows of a CSV after its header, split at commas; a last line without newline is not a row.
std::vector<std::vector<long long>> csv_rows(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  std::vector<std::vector<long long>> rows;
  std::size_t pos = text.find('\n');
  while (pos != std::string::npos && pos + 1 < text.size()) {
    const std::size_t end = text.find('\n', pos + 1);
    if (end == std::string::npos) break;  // cut last line
    std::vector<long long> row;
    std::istringstream line(text.substr(pos + 1, end - pos - 1));
    for (std::string cell; std::getline(line, cell, ',');) row.push_back(std::stoll(cell));
    rows.push_back(row);
    pos = end;
  }
  return rows;
}
int node_of(const fs::path& p, const char* prefix) {
  return std::stoi(p.stem().string().substr(std::string(prefix).size()));
}
}  // namespace

void check_raw_csvs(const RigRun& r, bool expect_complete) {
  const auto& s = r.summary;
  ASSERT_TRUE(s.is_object());
  // Publishers: node i publishes topic i (the runner starts publishers first). status 2 = not sent.
  std::map<long long, std::map<long long, long long>> sent;  // topic -> seq -> stamp
  std::uint64_t sent_rows = 0;
  std::map<int, std::vector<std::vector<long long>>> sub_rows;
  for (const auto& e : fs::directory_iterator(r.out)) {
    const auto name = e.path().filename().string();
    if (e.path().extension() != ".csv") continue;
    if (name.rfind("pub_", 0) == 0) {
      const int topic = node_of(e.path(), "pub_");
      for (const auto& row : csv_rows(e.path())) {
        ASSERT_EQ(row.size(), 5u) << name;
        if (row[4] == 2) continue;
        EXPECT_TRUE(sent[topic].emplace(row[0], row[2]).second) << name << ": seq " << row[0] << " twice";
        ++sent_rows;
      }
    } else if (name.rfind("sub_", 0) == 0) {
      sub_rows[node_of(e.path(), "sub_")] = csv_rows(e.path());
    }
  }
  EXPECT_EQ(sent_rows, s["sent"].get<std::uint64_t>());
  std::uint64_t distinct_total = 0;
  for (const auto& sub : s["per_subscriber"]) {
    const int node = sub["node"].get<int>();
    ASSERT_TRUE(sub_rows.count(node)) << "no sub_" << node << ".csv";
    std::set<std::pair<long long, long long>> distinct;
    std::set<long long> topics;
    std::uint64_t dups = 0, never = 0;
    for (const auto& row : sub_rows[node]) {
      ASSERT_EQ(row.size(), 4u);
      topics.insert(row[0]);
      const auto t = sent.find(row[0]);
      if (t == sent.end() || t->second.count(row[1]) == 0) {
        ++never;
        continue;
      }
      EXPECT_EQ(row[2], t->second.at(row[1])) << "sub_" << node << ": stamp of " << row[0] << "/" << row[1] << " differs from the publisher's";
      if (!distinct.emplace(row[0], row[1]).second) ++dups;
    }
    EXPECT_EQ(distinct.size(), sub["received"].get<std::uint64_t>()) << "sub_" << node;
    EXPECT_EQ(dups, sub["duplicates"].get<std::uint64_t>()) << "sub_" << node;
    EXPECT_EQ(never, sub["never_sent"].get<std::uint64_t>() + sub["unexpected"].get<std::uint64_t>()) << "sub_" << node;
    distinct_total += distinct.size();
    if (expect_complete) {
      // Exactly the ids its publishers sent: count by count per topic it heard from.
      std::uint64_t want = 0;
      for (long long t : topics) want += sent[t].size();
      EXPECT_EQ(distinct.size(), want) << "sub_" << node;
      EXPECT_EQ(static_cast<std::uint64_t>(topics.size()), sub["topics"].get<std::uint64_t>()) << "sub_" << node;
      EXPECT_EQ(dups, 0u);
      EXPECT_EQ(never, 0u);
    }
  }
  EXPECT_EQ(distinct_total, s["received"].get<std::uint64_t>());
}

}  // namespace sensor_rig::bench::perf::test
