#include "sensor_rig/bench/perf/analysis.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>

#include "sensor_rig/bench/perf/records.hpp"
#include "sensor_rig/bench/perf/stats.hpp"

namespace sensor_rig::bench::perf {
namespace {

using nlohmann::json;

json stats_json(const LatencyStats& s, bool full) {
  json j = {{"mean", s.mean}, {"p50", s.p50}, {"p90", s.p90}, {"p99", s.p99}, {"max", s.max}, {"std", s.std}};
  if (full) {
    j["min"] = s.min;
    j["p1"] = s.p1;
    j["p25"] = s.p25;
    j["p75"] = s.p75;
    j["n"] = s.n;
  }
  return j;
}

struct PubInfo {
  std::uint64_t on_time = 0, late = 0, not_sent = 0, missing_rows = 0;
  std::vector<Nanos> stamps;  // per seq: the stamp it was sent with, 0 = not sent
  std::uint64_t sent = 0;
  std::vector<double> write_ms;
  bool known = false;  // its CSV was readable and had records
  [[nodiscard]] bool was_sent(std::uint32_t seq) const { return seq < stamps.size() && stamps[seq] != 0; }
};

struct SubTopic {
  std::map<std::uint32_t, Nanos> recv;  // seq -> receive time (first copy)
};

// Reads a publisher's CSV. Every planned message lands in exactly one category: rows missing from
// the CSV and a publisher that left no records at all count as not sent.
PubInfo read_publisher(const NodeOutcome& n, std::uint32_t count) {
  PubInfo p;
  p.stamps.assign(count, 0);
  std::vector<bool> seen(count, false);
  if (std::filesystem::exists(n.csv)) {
    CsvStats cs;
    for (const auto& r : read_pub_csv(n.csv, &cs)) {
      if (r.seq >= count || seen[r.seq]) continue;
      seen[r.seq] = true;
      if (r.status == SendStatus::kNotSent || r.stamp_ns == 0) continue;
      ++(r.status == SendStatus::kOnTime ? p.on_time : p.late);
      p.stamps[r.seq] = r.stamp_ns;
      ++p.sent;
      p.write_ms.push_back(static_cast<double>(r.write_ns) / 1e6);
    }
    p.known = cs.rows > 0;
  }
  if (p.known) p.missing_rows = static_cast<std::uint64_t>(std::count(seen.begin(), seen.end(), false));
  p.not_sent = count - p.on_time - p.late;
  return p;
}

// Loaned writes and zero-copy takes, from the nodes' exit stats (node_<i>.json).
json data_paths(const RunInput& in, json& procs) {
  std::uint64_t loaned = 0, copied = 0, zero_copy = 0, copied_takes = 0;
  int reporting = 0;
  for (std::size_t i = 0; i < in.nodes.size(); ++i) {
    const auto& n = in.nodes[i];
    if (n.stats.empty() || !std::filesystem::exists(n.stats)) continue;
    std::ifstream f(n.stats);
    const json d = json::parse(f, nullptr, false);
    if (!d.is_object()) continue;
    ++reporting;
    procs[i]["data_path"] = d;
    loaned += d.value("loaned_writes", std::uint64_t{0});
    copied += d.value("copied_writes", std::uint64_t{0});
    zero_copy += d.value("zero_copy_takes", std::uint64_t{0});
    copied_takes += d.value("copied_takes", std::uint64_t{0});
  }
  std::string how;
  if (in.spec.transport != Transport::kShm) how = "serialised and sent over loopback UDP";
  else if (in.spec.message == Message::kFixed) how = "loaned iceoryx chunks: written in place, read in place (zero copy)";
  else if (in.spec.reader == ReaderMode::kView)
    how = "Cyclone 0.10 cannot loan a type with sequences/strings: the writer serialises each sample into an "
          "iceoryx chunk and every reader reads it there as a view (one copy, the writer's)";
  else how = "Cyclone 0.10 cannot loan a type with sequences/strings: the writer serialises each sample into an "
             "iceoryx chunk and every reader deserialises it (no loan, one copy per side)";
  return {{"expected_path", how}, {"nodes_reporting", reporting}, {"nodes", in.nodes.size()},
          {"loaned_writes", loaned}, {"copied_writes", copied}, {"zero_copy_takes", zero_copy},
          {"copied_takes", copied_takes}, {"writers_used_loans", loaned > 0 && copied == 0},
          {"readers_took_zero_copy", zero_copy > 0 && copied_takes == 0}};
}

}  // namespace

std::string NodeOutcome::status() const {
  if (ok()) return "ok";
  if (stopped_by_runner) return "stopped by runner after timeout";
  if (!exited) return "not reaped";
  if (term_signal != 0) return "killed by signal " + std::to_string(term_signal);
  return "exit code " + std::to_string(exit_code);
}

json analyse(const RunInput& in) {
  const RunSpec& spec = in.spec;
  const Nanos period = static_cast<Nanos>(1e9 / spec.rate_hz);
  const std::uint32_t count = spec.count();
  json warnings = in.warnings;
  auto warn_count = [&](std::uint64_t n, const std::string& what) {
    if (n > 0) warnings.push_back(std::to_string(n) + " " + what);
  };

  // Publishers.
  std::map<int, PubInfo> pubs;  // topic -> info
  json pub_list = json::array();
  for (const auto& n : in.nodes) {
    if (n.plan.role != Role::kPublisher) continue;
    const int topic = n.plan.topics.front();
    PubInfo& p = pubs[topic] = read_publisher(n, count);
    if (!p.known) {
      warnings.push_back("publisher node " + std::to_string(n.plan.index) + " failed (" + n.status() +
                         ") and left no records: its " + std::to_string(count) +
                         " messages count as not sent; copies its subscribers got count as never_sent");
    }
    warn_count(p.missing_rows, "messages missing from publisher node " + std::to_string(n.plan.index) +
                                   "'s records: counted as not sent");
    auto ws = compute_stats(p.write_ms);
    pub_list.push_back({{"node", n.plan.index}, {"topic", topic}, {"sent_on_time", p.on_time},
                        {"sent_late", p.late}, {"not_sent", p.not_sent}, {"records", p.known},
                        {"failed", !n.ok()}, {"status", n.status()},
                        {"write_ms", {{"mean", ws.mean}, {"p99", ws.p99}, {"max", ws.max}}}});
  }

  // Subscribers. Each row is one sample taken: a first copy of a message its publisher sent
  // (received), or counted apart: a second copy (duplicate), an id its publisher did not send
  // (never_sent), a topic it does not subscribe / an impossible id (unexpected).
  std::vector<double> all_ms;
  std::map<std::pair<int, std::uint32_t>, std::vector<std::pair<Nanos, int>>> arrivals;  // (topic,seq) -> (recv, node)
  struct SubAgg {
    int node = 0;
    std::map<int, SubTopic> topics;
    std::vector<double> ms;
    std::uint64_t duplicates = 0, unexpected = 0, never_sent = 0, stamp_mismatch = 0, in_time = 0, late = 0;
    std::string status;
    std::size_t malformed = 0;
  };
  std::vector<SubAgg> subs;
  for (const auto& n : in.nodes) {
    if (n.plan.role != Role::kSubscriber) continue;
    SubAgg a;
    a.node = n.plan.index;
    a.status = n.status();
    for (int t : n.plan.topics) a.topics[t];
    if (std::filesystem::exists(n.csv)) {
      CsvStats cs;
      for (const auto& r : read_sub_csv(n.csv, &cs)) {
        const int topic = static_cast<int>(r.topic);
        auto it = a.topics.find(topic);
        if (it == a.topics.end() || r.seq >= count) {
          ++a.unexpected;
          continue;
        }
        const PubInfo& pub = pubs[topic];
        if (!pub.was_sent(r.seq)) {
          ++a.never_sent;
          continue;
        }
        if (!it->second.recv.emplace(r.seq, r.recv_ns).second) {
          ++a.duplicates;
          continue;
        }
        if (r.stamp_ns != pub.stamps[r.seq]) ++a.stamp_mismatch;
        const double ms = static_cast<double>(r.recv_ns - r.stamp_ns) / 1e6;
        a.ms.push_back(ms);
        all_ms.push_back(ms);
        (r.recv_ns - r.stamp_ns <= period ? a.in_time : a.late) += 1;
        arrivals[{topic, r.seq}].emplace_back(r.recv_ns, a.node);
      }
      a.malformed = cs.malformed;
    } else {
      warnings.push_back("subscriber node " + std::to_string(a.node) + " left no CSV (" + a.status + ")");
    }
    subs.push_back(std::move(a));
  }

  // Delivery order among subscribers of the same message (fairness, paper Fig. 14).
  std::map<int, std::pair<double, std::uint64_t>> rank_sum;  // node -> (sum of normalised ranks, n)
  for (auto& [key, v] : arrivals) {
    if (v.size() < 2) continue;
    std::sort(v.begin(), v.end());
    for (std::size_t i = 0; i < v.size(); ++i) {
      auto& rs = rank_sum[v[i].second];
      rs.first += static_cast<double>(i) / static_cast<double>(v.size() - 1);
      rs.second += 1;
    }
  }

  std::uint64_t sent = 0, on_time = 0, late = 0, not_sent = 0;
  for (const auto& [t, p] : pubs) {
    on_time += p.on_time;
    late += p.late;
    not_sent += p.not_sent;
    sent += p.sent;
  }
  std::uint64_t received = 0, lost = 0, expected = 0, in_time = 0, sub_late = 0, dups = 0, never = 0, unexpected = 0,
                mismatch = 0, malformed = 0;
  int subscriptions = 0;
  json sub_list = json::array();
  std::vector<double> fair_recv, fair_lat;
  for (auto& a : subs) {
    std::uint64_t r = 0, e = 0;
    for (const auto& [t, st] : a.topics) {
      e += pubs[t].sent;
      r += st.recv.size();
    }
    subscriptions += static_cast<int>(a.topics.size());
    received += r;
    expected += e;
    lost += e - r;
    in_time += a.in_time;
    sub_late += a.late;
    dups += a.duplicates;
    never += a.never_sent;
    unexpected += a.unexpected;
    mismatch += a.stamp_mismatch;
    malformed += a.malformed;
    const double ratio = e > 0 ? static_cast<double>(r) / static_cast<double>(e) : 1.0;
    auto s = compute_stats(a.ms);
    json j = {{"node", a.node}, {"topics", a.topics.size()}, {"expected", e}, {"received", r}, {"lost", e - r},
              {"delivery_ratio", ratio}, {"in_time", a.in_time}, {"late", a.late}, {"duplicates", a.duplicates},
              {"never_sent", a.never_sent}, {"unexpected", a.unexpected}, {"stamp_mismatch", a.stamp_mismatch},
              {"latency_ms", stats_json(s, false)}, {"status", a.status}};
    if (auto it = rank_sum.find(a.node); it != rank_sum.end() && it->second.second > 0) {
      j["mean_rank"] = it->second.first / static_cast<double>(it->second.second);
    }
    if (a.malformed > 0) j["malformed_rows"] = a.malformed;
    sub_list.push_back(j);
    fair_recv.push_back(ratio);
    if (s.n > 0) fair_lat.push_back(s.mean);
  }
  warn_count(dups, "duplicate copies received (counted apart, not as received)");
  warn_count(never, "samples with ids their publisher's records do not show as sent (never_sent, not counted as received)");
  warn_count(unexpected, "samples on topics not subscribed or with impossible ids (unexpected)");
  warn_count(mismatch, "samples whose stamp differs from the publisher's record (stamp_mismatch)");
  warn_count(malformed, "malformed or cut subscriber CSV rows ignored");

  json procs = json::array();
  json failed = json::array();
  for (const auto& n : in.nodes) {
    procs.push_back({{"node", n.plan.index}, {"role", n.plan.role == Role::kPublisher ? "pub" : "sub"},
                     {"pid", n.pid}, {"cpu_s", n.cpu_s}, {"max_rss_kb", n.max_rss_kb}, {"status", n.status()}});
    if (!n.ok()) failed.push_back({{"node", n.plan.index}, {"role", n.plan.role == Role::kPublisher ? "pub" : "sub"},
                                   {"pid", n.pid}, {"status", n.status()}});
  }
  const json loans = data_paths(in, procs);

  const auto ls = compute_stats(all_ms);
  json j = {{"topology", spec.topology}, {"nodes", spec.nodes}, {"size", spec.size}, {"rate_hz", spec.rate_hz},
            {"transport", to_string(spec.transport)}, {"sent", sent}, {"received", received}, {"lost", lost},
            {"sent_on_time", on_time}, {"sent_late", late}, {"not_sent", not_sent},
            {"latency_ms", stats_json(ls, true)}};
  j["size_label"] = size_label(spec.size);
  j["duration_s"] = spec.duration_s;
  j["message"] = to_string(spec.message);
  if (spec.message == Message::kPointCloud2) j["reader"] = to_string(spec.reader);
  j["depth"] = spec.depth;
  j["rt_priority"] = spec.rt_priority;
  j["domain"] = in.domain;
  j["count_per_publisher"] = count;
  j["publishers"] = publisher_count(spec);
  j["subscriber_nodes"] = subs.size();
  j["subscriptions"] = subscriptions;
  j["expected"] = expected;  // sum over subscriptions of what their publisher sent = received + lost
  j["loss_pct"] = expected > 0 ? 100.0 * static_cast<double>(lost) / static_cast<double>(expected) : 0.0;
  j["received_in_time"] = in_time;
  j["received_late"] = sub_late;
  j["duplicates"] = dups;
  j["never_sent"] = never;
  j["unexpected"] = unexpected;
  j["stamp_mismatch"] = mismatch;
  j["t0_ns"] = in.t0_ns;
  j["fairness"] = {{"jain_delivery_ratio", jain_index(fair_recv)}, {"jain_mean_latency", jain_index(fair_lat)}};
  j["loans"] = loans;
  j["per_publisher"] = pub_list;
  j["per_subscriber"] = sub_list;
  j["processes"] = procs;
  j["failed_nodes"] = failed;
  j["warnings"] = warnings;
  for (auto it = in.extra.begin(); it != in.extra.end(); ++it) j[it.key()] = it.value();
  return j;
}

}  // namespace sensor_rig::bench::perf

namespace sensor_rig::bench::perf {
std::string summary_line(const nlohmann::json& s) {
  char buf[512];
  const auto& l = s["latency_ms"];
  std::snprintf(buf, sizeof buf,
                "%s: sent %llu (on time %llu, late %llu, not sent %llu) received %llu lost %llu (%.3f %%) "
                "latency ms mean %.3f p50 %.3f p99 %.3f max %.3f%s",
                s.value("label", std::string("run")).c_str(), s["sent"].get<unsigned long long>(),
                s["sent_on_time"].get<unsigned long long>(), s["sent_late"].get<unsigned long long>(),
                s["not_sent"].get<unsigned long long>(), s["received"].get<unsigned long long>(),
                s["lost"].get<unsigned long long>(), s.value("loss_pct", 0.0), l["mean"].get<double>(),
                l["p50"].get<double>(), l["p99"].get<double>(), l["max"].get<double>(),
                s["failed_nodes"].empty() ? "" : "  FAILED NODES");
  return buf;
}
}  // namespace sensor_rig::bench::perf
