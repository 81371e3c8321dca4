// The judge's verdict for people (a table and one line per invariant) and for programs (the --json line).
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

std::string result_json(const Result& r) {
  nlohmann::json j;
  j["faults"] = nlohmann::json::object();
  for (const auto& [k, n] : r.faults) j["faults"][k] = n;
  j["topics"] = nlohmann::json::object();
  for (const auto& [topic, t] : r.topics) {
    j["topics"][topic] = {{"device", t.device},
                          {"sent", t.sent},
                          {"published_complete", t.published_complete},
                          {"published_incomplete", t.published_incomplete},
                          {"counted_lost", t.counted_lost},
                          {"counted_unheard", t.counted_unheard},
                          {"unaccounted", t.unaccounted},
                          {"phantom_missing", t.phantom_missing},
                          {"hidden_missing", t.hidden_missing},
                          {"published_twice", t.published_twice},
                          {"unmatched", t.unmatched},
                          {"stamp_error_p50_ms", t.stamp_error_p50_ms},
                          {"stamp_error_p99_ms", t.stamp_error_p99_ms},
                          {"stamp_error_max_ms", t.stamp_error_max_ms},
                          {"stamps_flagged", t.stamps_flagged},
                          {"mixes_flagged", t.mixes_flagged},
                          {"mixes_regrouped", t.mixes_regrouped},
                          {"healthy_rate_share", t.healthy_rate_share},
                          {"recovery_max_s", t.recovery_max_s},
                          {"monitor", {{"received", t.monitor_received}, {"lost", t.monitor_lost}, {"expected", t.monitor_expected}}}};
  }
  j["invariants"] = nlohmann::json::object();
  for (const auto& [k, held] : r.invariants) j["invariants"][k] = held ? "held" : "broken";
  j["examples"] = nlohmann::json::array();
  for (const auto& e : r.examples) j["examples"].push_back({{"invariant", e.invariant}, {"topic", e.topic}, {"what", e.what}});
  if (!r.faults_not_injected.empty()) j["faults_not_injected"] = r.faults_not_injected;
  if (!r.campaign_errors.empty()) j["campaign_errors"] = r.campaign_errors;
  return j.dump();
}

std::string result_text(const Result& r) {
  std::ostringstream o;
  o << "faults injected:";
  for (const auto& [k, n] : r.faults) o << ' ' << k << '=' << n;
  o << '\n';
  char line[320];
  std::snprintf(line, sizeof line, "%-40s %6s %8s %8s %6s %7s %6s %7s %7s %8s %7s\n", "topic", "sent", "complete", "incompl",
                "lost", "unheard", "unacc", "phantom", "hidden", "stamp99", "healthy");
  o << line;
  for (const auto& [topic, t] : r.topics) {
    std::snprintf(line, sizeof line, "%-40s %6llu %8llu %8llu %6llu %7llu %6llu %7llu %7llu %8.3f %6.1f%%\n", topic.c_str(),
                  static_cast<unsigned long long>(t.sent), static_cast<unsigned long long>(t.published_complete),
                  static_cast<unsigned long long>(t.published_incomplete), static_cast<unsigned long long>(t.counted_lost),
                  static_cast<unsigned long long>(t.counted_unheard), static_cast<unsigned long long>(t.unaccounted), static_cast<unsigned long long>(t.phantom_missing),
                  static_cast<unsigned long long>(t.hidden_missing), t.stamp_error_p99_ms, 100 * t.healthy_rate_share);
    o << line;
  }
  for (const auto& e : r.campaign_errors) o << "ERROR  " << e << '\n';
  for (const auto& [name, held] : r.invariants) {
    o << (held ? "held   " : "BROKEN ") << name << '\n';
    for (const auto& e : r.examples)
      if (e.invariant == name) o << "         " << e.topic << ": " << e.what << '\n';
  }
  return o.str();
}

}  // namespace sensor_rig::rig::chaos
