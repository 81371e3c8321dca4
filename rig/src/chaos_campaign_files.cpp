#include "chaos_campaign_files.hpp"

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig::chaos {
namespace fs = std::filesystem;
namespace {

// judge.json's format: a reader refuses what it does not know rather than judge a guess.
constexpr int kJudgeFormat = 1;

nlohmann::json expectation_json(const TopicExpectation& e) {
  return {{"device", e.device}, {"rate_hz", e.rate_hz}, {"depends_on", e.depends_on}};
}

}  // namespace

std::vector<truth::Log> read_truths(const fs::path& dir) {
  std::vector<truth::Log> out;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".jsonl") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    out.push_back(truth::read(f.string()));
    if (out.back().cut_last_line) log::warn("chaos", f.string() + ": last line cut (its mock was killed mid-write)");
  }
  return out;
}

void write_fused_sets(const std::string& path, const std::vector<FusedSet>& sets) {
  std::ofstream f(path);
  for (const auto& s : sets) {
    nlohmann::json j{{"seq", s.seq}, {"stamp", s.stamp}, {"members", nlohmann::json::array()}};
    for (const auto& m : s.members) j["members"].push_back({{"topic", m.topic}, {"stamp", m.stamp}, {"seq", m.seq}});
    f << j.dump() << '\n';
  }
}

std::vector<FusedSet> read_fused_sets(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot read");
  std::vector<FusedSet> out;
  int n = 0;
  for (std::string line; std::getline(f, line);) {
    ++n;
    if (line.empty()) continue;
    try {
      const auto j = nlohmann::json::parse(line);
      FusedSet s{j.at("seq").get<std::uint64_t>(), j.at("stamp").get<Nanos>(), {}};
      for (const auto& m : j.at("members")) s.members.push_back({m.at("topic").get<std::string>(), m.at("stamp").get<Nanos>(), m.at("seq").get<std::uint64_t>()});
      out.push_back(std::move(s));
    } catch (const nlohmann::json::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(n) + ": not a fused sweep: " + e.what());
    }
  }
  return out;
}

void write_judge_input(const std::string& path, const Input& in, const std::vector<std::string>& campaign_errors) {
  nlohmann::json j{{"judge", kJudgeFormat},
                   {"epoch_vehicle_ns", in.epoch_vehicle_ns},
                   {"window_begin_ns", in.window_begin_ns},
                   {"window_end_ns", in.window_end_ns},
                   {"count_edge_ns", in.count_edge_ns},
                   {"counted_lost", in.counted_lost},
                   {"unheard", in.unheard},
                   {"dbw_ecu_timeout_ns", in.dbw_ecu_timeout_ns},
                   {"dbw_gaps_unknown", in.dbw_gaps_unknown},
                   {"campaign_errors", campaign_errors}};
  auto& monitor = j["monitor"] = nlohmann::json::object();
  for (const auto& [topic, m] : in.monitor) monitor[topic] = {{"received", m.received}, {"lost", m.lost}};
  auto& expected = j["expected"] = nlohmann::json::object();
  for (const auto& [topic, e] : in.expected) expected[topic] = expectation_json(e);
  auto& unsynchronized = j["unsynchronized"] = nlohmann::json::object();
  for (const auto& [topic, spans] : in.unsynchronized) unsynchronized[topic] = spans;
  j["dbw_bridge"] = in.dbw_bridge;
  j["fused"] = {{"enabled", in.fused.enabled},
                {"lidar_topics", in.fused.lidar_topics},
                {"period_ns", in.fused.period_ns},
                {"scans_dropped", in.fused.scans_dropped}};
  std::ofstream(path) << j.dump(1) << '\n';
}

Input read_campaign(const fs::path& dir, std::vector<std::string>& campaign_errors) {
  const fs::path judge = dir / "judge.json";
  std::ifstream f(judge);
  if (!f) throw std::runtime_error(judge.string() + ": cannot read (a campaign kept with `rig chaos --out` before judge.json existed cannot be judged again)");
  const auto j = nlohmann::json::parse(f, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw std::runtime_error(judge.string() + ": not JSON");
  if (j.value("judge", 0) != kJudgeFormat)
    throw std::runtime_error(judge.string() + ": format " + std::to_string(j.value("judge", 0)) + ", this rig reads " + std::to_string(kJudgeFormat));
  Input in;
  try {
    in.epoch_vehicle_ns = j.at("epoch_vehicle_ns").get<Nanos>();
    in.window_begin_ns = j.at("window_begin_ns").get<Nanos>();
    in.window_end_ns = j.at("window_end_ns").get<Nanos>();
    in.count_edge_ns = j.at("count_edge_ns").get<Nanos>();
    in.counted_lost = j.at("counted_lost").get<std::map<std::string, std::uint64_t>>();
    // Campaigns judged before LIDARs counted unheard turns have none.
    if (j.contains("unheard")) in.unheard = j.at("unheard").get<std::map<std::string, std::uint64_t>>();
    in.dbw_ecu_timeout_ns = j.at("dbw_ecu_timeout_ns").get<Nanos>();
    in.dbw_gaps_unknown = j.value("dbw_gaps_unknown", std::uint64_t{0});  // campaigns kept before 2026-12-01: none
    campaign_errors = j.at("campaign_errors").get<std::vector<std::string>>();
    for (const auto& [topic, m] : j.at("monitor").items()) in.monitor[topic] = {m.at("received").get<std::uint64_t>(), m.at("lost").get<std::uint64_t>()};
    for (const auto& [topic, e] : j.at("expected").items())
      in.expected[topic] = {e.at("device").get<std::string>(), e.at("rate_hz").get<double>(), e.at("depends_on").get<std::vector<std::string>>()};
    in.unsynchronized = j.at("unsynchronized").get<std::map<std::string, std::vector<std::pair<Nanos, Nanos>>>>();
    in.dbw_bridge = j.at("dbw_bridge").get<std::vector<std::pair<Nanos, std::string>>>();
    const auto& fused = j.at("fused");
    in.fused.enabled = fused.at("enabled").get<bool>();
    in.fused.lidar_topics = fused.at("lidar_topics").get<std::vector<std::string>>();
    in.fused.period_ns = fused.at("period_ns").get<Nanos>();
    in.fused.scans_dropped = fused.at("scans_dropped").get<std::uint64_t>();
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(judge.string() + ": " + e.what());
  }
  in.events = faults::read_plan((dir / "plan.jsonl").string()).events;
  in.truths = read_truths(dir / "truth");
  in.samples = read_records((dir / "monitor.csv").string());
  if (in.fused.enabled) in.fused.sets = read_fused_sets((dir / "fused_sets.jsonl").string());
  return in;
}

}  // namespace sensor_rig::rig::chaos
