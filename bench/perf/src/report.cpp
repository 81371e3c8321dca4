#include "sensor_rig/bench/perf/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <functional>
#include <map>
#include <tuple>

#include "sensor_rig/bench/perf/records.hpp"
#include "sensor_rig/bench/perf/spec.hpp"
#include "sensor_rig/bench/perf/stats.hpp"
#include "sensor_rig/common/svg.hpp"

namespace sensor_rig::bench::perf {
namespace fs = std::filesystem;
using nlohmann::json;
namespace {

constexpr const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

struct Run {
  fs::path dir;
  json s;
  std::vector<double> latency_ms;  // every row of its subscriber CSVs (pooled by Figs. 9-10)
  [[nodiscard]] std::string label() const { return s.value("label", dir.filename().string()); }
};

std::vector<SubRecord> read_sub_rows(const fs::path& dir) {
  std::vector<SubRecord> all;
  for (const auto& e : fs::directory_iterator(dir)) {
    const auto n = e.path().filename().string();
    if (n.rfind("sub_", 0) == 0 && e.path().extension() == ".csv") {
      auto v = read_sub_csv(e.path().string());
      all.insert(all.end(), v.begin(), v.end());
    }
  }
  return all;
}

std::vector<Run> find_runs(const fs::path& dir) {
  std::vector<Run> runs;
  auto load = [&](const fs::path& p) {
    std::ifstream in(p);
    try {
      Run r{p.parent_path(), json::parse(in), {}};
      for (const auto& row : read_sub_rows(r.dir)) r.latency_ms.push_back(static_cast<double>(row.recv_ns - row.stamp_ns) / 1e6);
      runs.push_back(std::move(r));
    } catch (const std::exception&) {
      // unreadable summary: not a run
    }
  };
  if (fs::exists(dir / "summary.json")) load(dir / "summary.json");
  if (fs::is_directory(dir)) {
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (e.path().filename() == "summary.json" && e.path().parent_path() != dir) load(e.path());
    }
  }
  std::sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) {
    auto key = [](const json& s) {
      return std::tuple(s.value("rate_hz", 0.0), s.value("size", 0u), s.value("nodes", 0), s.value("topology", 0),
                        s.value("transport", std::string()));
    };
    return key(a.s) < key(b.s);
  });
  return runs;
}

double ms(const json& s, const char* k) { return s["latency_ms"].value(k, 0.0); }

std::string fmt(int prec, double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", prec, v);
  return b;
}

// Fig. 8: latency over time of every subscription, subsampled to at most ~4000 points.
std::string latency_over_time(const Run& r) {
  const Nanos t0 = r.s.value("t0_ns", Nanos{0});
  const std::vector<SubRecord> all = read_sub_rows(r.dir);
  svg::Series s{"latency", kColors[0], {}, {}};
  const std::size_t step = std::max<std::size_t>(1, all.size() / 4000);
  double ymax = 0.001, ymin = 1e9;
  for (std::size_t i = 0; i < all.size(); i += step) {
    const double l = static_cast<double>(all[i].recv_ns - all[i].stamp_ns) / 1e6;
    s.x.push_back(static_cast<double>(all[i].stamp_ns - t0) / 1e9);
    s.y.push_back(l);
    ymax = std::max(ymax, l);
    ymin = std::min(ymin, l);
  }
  if (s.x.empty()) return "<p>no samples</p>";
  const double dur = r.s.value("duration_s", 1.0);
  return svg::scatter("Latency over time - " + r.label(), {0, dur, false, "time since start (s)"},
                      {std::max(0.001, std::pow(10.0, std::floor(std::log10(std::max(ymin, 1e-3))))), ymax * 1.2, true, "latency (ms, log)"},
                      {s});
}

// Figs. 9-10: the latencies of every run in a group pooled into one box (the paper's boxes are per
// message size and per subscriber count, not per run). One chart per `chart` key, one box per `box`
// key; runs without subscriber CSVs cannot be pooled and are left out (said under the chart).
template <class ChartKey, class BoxKey>
std::string pooled_boxes(const std::vector<Run>& runs, const std::string& fig,
                         const std::function<ChartKey(const json&)>& chart_of,
                         const std::function<std::string(const ChartKey&)>& chart_title,
                         const std::function<BoxKey(const json&)>& box_of,
                         const std::function<std::string(const BoxKey&)>& box_label) {
  struct Pool {
    std::vector<double> ms;
    int runs = 0;
  };
  std::map<ChartKey, std::map<BoxKey, Pool>> charts;
  int without_samples = 0;
  for (const auto& r : runs) {
    if (r.latency_ms.empty()) {
      ++without_samples;
      continue;
    }
    Pool& p = charts[chart_of(r.s)][box_of(r.s)];
    p.ms.insert(p.ms.end(), r.latency_ms.begin(), r.latency_ms.end());
    ++p.runs;
  }
  std::ostringstream h;
  for (auto& [ck, boxes] : charts) {
    std::vector<svg::Box> b;
    double lo = 1e9, hi = 0.001;
    for (auto& [bk, pool] : boxes) {
      const auto st = compute_stats(pool.ms);
      b.push_back({box_label(bk) + " (" + std::to_string(pool.runs) + (pool.runs == 1 ? " run, " : " runs, ") +
                       std::to_string(st.n) + " msgs)",
                   st.p1, st.p25, st.p50, st.p75, st.p99, st.max, st.mean});
      lo = std::min(lo, std::max(1e-3, st.p1));
      hi = std::max(hi, st.max);
    }
    const svg::Axis y{std::pow(10.0, std::floor(std::log10(lo))), hi * 1.2, true, "latency (ms, log)"};
    h << svg::boxes(fig + ": " + chart_title(ck), y, b);
  }
  if (without_samples > 0) h << "<p>" << without_samples << " run(s) without subscriber CSVs left out.</p>";
  if (charts.empty()) h << "<p>no samples</p>";
  return h.str();
}

using SeriesKey = std::tuple<std::string, std::string, double>;  // transport, message, rate
SeriesKey series_of(const json& s) {
  return {s.value("transport", std::string("?")), s.value("message", std::string("fixed")), s.value("rate_hz", 0.0)};
}
std::string series_title(const SeriesKey& k) {
  char b[128];
  std::snprintf(b, sizeof b, "%s, %s, %g Hz", std::get<0>(k).c_str(), std::get<1>(k).c_str(), std::get<2>(k));
  return b;
}
int subscriptions_of(const json& s) {
  if (s.contains("subscriptions")) return s["subscriptions"].get<int>();
  int n = 0;  // summaries written before the key existed
  for (const auto& sub : s.value("per_subscriber", json::array())) n += sub.value("topics", 1);
  return n;
}

}  // namespace

// Only what SPEC §1 states about the paper (Kouril et al.); "—" where it gives no figure.
std::string paper_reference(const json& s) {
  const auto size = s.value("size", 0u);
  const int nodes = s.value("nodes", 0);
  const int topo = s.value("topology", 0);
  const double rate = s.value("rate_hz", 0.0);
  std::vector<std::string> refs;
  if (size == 1048576 && nodes == 32 && topo == 2 && rate == 10.0) refs.emplace_back("Cyclone 15–20 ms mean, Fast DDS 8 ms");
  if (size >= 524288 && rate == 10.0) refs.emplace_back("not all 600 messages of a 60 s run sent on time");
  if (refs.empty()) return "—";
  std::string out = refs.front();
  for (std::size_t i = 1; i < refs.size(); ++i) out += "; " + refs[i];
  return out;
}

std::string markdown_table(const std::vector<json>& summaries) {
  std::ostringstream o;
  o << "Paper headline (Kouril et al., \"Performance Evaluation of a ROS2 Based Automated Driving System\"): "
       "most latencies < 2 ms; PointCloud1m (1 MB) to 31 "
       "subscribers 15–20 ms mean with Cyclone DDS, 8 ms with Fast DDS; loss up to 0.88 %; from 512 kB up publishers "
       "could not send all 600 messages of a 60 s run on time. The paper column gives a figure only for runs it "
       "states one for (—: none stated).\n\n";
  o << "| run | sent | on time | late | not sent | received | lost (%) | mean ms | p50 | p90 | p99 | max | paper (Kouril et al.) |\n"
    << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const auto& s : summaries) {
    o << "| " << s.value("label", std::string("?")) << (s["failed_nodes"].empty() ? "" : " (failed nodes)") << " | "
      << s["sent"] << " | " << s["sent_on_time"] << " | " << s["sent_late"] << " | " << s["not_sent"] << " | "
      << s["received"] << " | " << s["lost"] << " (" << fmt(3, s.value("loss_pct", 0.0)) << ") | "
      << fmt(3, ms(s, "mean")) << " | " << fmt(3, ms(s, "p50")) << " | " << fmt(3, ms(s, "p90")) << " | "
      << fmt(3, ms(s, "p99")) << " | " << fmt(3, ms(s, "max")) << " | " << paper_reference(s) << " |\n";
  }
  return o.str();
}

ReportResult write_report(const std::string& dir_s) {
  const fs::path dir = fs::absolute(dir_s);
  if (!fs::is_directory(dir)) throw std::runtime_error("'" + dir_s + "' is not a directory");
  const auto runs = find_runs(dir);
  ReportResult res;
  res.runs = static_cast<int>(runs.size());
  std::vector<json> sums;
  sums.reserve(runs.size());
  for (const auto& r : runs) sums.push_back(r.s);

  std::ostringstream h;
  h << "<!doctype html><html><head><meta charset='utf-8'><title>rig perf report</title><style>"
       "body{font-family:sans-serif;margin:20px;max-width:1000px}table{border-collapse:collapse;font-size:12px}"
       "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#eee}td:first-child{text-align:left}"
       "</style></head><body><h1>rig perf report</h1><p>"
    << svg::escape(dir.string()) << ": " << runs.size()
    << " run(s). Latency = subscriber receive time - header stamp written immediately before the DDS write "
       "(CLOCK_REALTIME, same host).</p>";
  if (runs.empty()) h << "<p>No summary.json found.</p>";

  // Summary table.
  h << "<h2>Runs</h2><table><tr><th>run</th><th>sent</th><th>on time</th><th>late</th><th>not sent</th><th>received</th>"
       "<th>lost</th><th>mean</th><th>p50</th><th>p90</th><th>p99</th><th>max</th><th>std</th><th>CPU s</th><th>max RSS MB</th>"
       "<th>RouDi CPU s / RSS MB</th><th>status</th></tr>";
  for (const auto& r : runs) {
    const auto& s = r.s;
    double cpu = 0, rss = 0;
    for (const auto& p : s["processes"]) {
      cpu += p.value("cpu_s", 0.0);
      rss = std::max(rss, p.value("max_rss_kb", 0.0) / 1024.0);
    }
    h << "<tr><td>" << svg::escape(r.label()) << "</td><td>" << s["sent"] << "</td><td>" << s["sent_on_time"] << "</td><td>"
      << s["sent_late"] << "</td><td>" << s["not_sent"] << "</td><td>" << s["received"] << "</td><td>" << s["lost"] << " ("
      << fmt(3, s.value("loss_pct", 0.0)) << " %)</td>";
    for (const char* k : {"mean", "p50", "p90", "p99", "max", "std"}) h << "<td>" << fmt(3, ms(s, k)) << "</td>";
    h << "<td>" << fmt(1, cpu) << "</td><td>" << fmt(0, rss) << "</td><td>";
    if (s.contains("roudi") && s["roudi"].contains("cpu_s")) {
      h << fmt(1, s["roudi"].value("cpu_s", 0.0)) << " / " << fmt(0, s["roudi"].value("max_rss_kb", 0.0) / 1024.0);
    } else {
      h << "—";
    }
    h << "</td><td>"
      << (s["failed_nodes"].empty() ? "ok" : svg::escape(s["failed_nodes"].dump())) << "</td></tr>";
  }
  h << "</table>";

  // Fig. 8: latency over time, for the heaviest runs (at most 6).
  std::vector<const Run*> heavy;
  heavy.reserve(runs.size());
  for (const auto& r : runs) heavy.push_back(&r);
  std::sort(heavy.begin(), heavy.end(), [](const Run* a, const Run* b) {
    return a->s.value("size", 0u) * a->s.value("received", 0ull) > b->s.value("size", 0u) * b->s.value("received", 0ull);
  });
  if (heavy.size() > 6) heavy.resize(6);
  h << "<h2>Latency over time (paper Fig. 8)</h2>";
  for (const Run* r : heavy) h << latency_over_time(*r);

  // Figs. 9-10: every message's latency pooled per message size and per subscriber count.
  h << "<h2>Latency per message size (paper Fig. 9)</h2><p>One chart per transport, message type and rate; one box "
       "per size pooling every received message of every run with that size (all topologies and node counts). "
       "Box p25-p75, red line median, whiskers p1-p99, circle max.</p>";
  h << pooled_boxes<SeriesKey, std::uint32_t>(
      runs, "Fig. 9", series_of, series_title, [](const json& s) { return s.value("size", 0u); },
      [](const std::uint32_t& size) { return size_label(size); });
  h << "<h2>Latency per subscriber count (paper Fig. 10)</h2><p>One chart per transport, message type, rate and "
       "size; one box per number of subscriptions (readers) in the run, pooling all topologies with that count.</p>";
  using SizedKey = std::tuple<SeriesKey, std::uint32_t>;
  h << pooled_boxes<SizedKey, int>(
      runs, "Fig. 10", [](const json& s) { return SizedKey{series_of(s), s.value("size", 0u)}; },
      [](const SizedKey& k) { return series_title(std::get<0>(k)) + ", " + size_label(std::get<1>(k)); }, subscriptions_of,
      [](const int& n) { return std::to_string(n) + (n == 1 ? " sub" : " subs"); });

  // Fig. 11: categories.
  std::vector<svg::Stack> pub_rows, sub_rows;
  for (const auto& r : runs) {
    const auto& s = r.s;
    const double total = s.value("count_per_publisher", 0.0) * s.value("publishers", 0.0);
    if (total > 0) {
      pub_rows.push_back({r.label(), {s.value("sent_on_time", 0.0) / total, s.value("sent_late", 0.0) / total,
                                      s.value("not_sent", 0.0) / total}});
    }
    const double exp = s.value("expected", 0.0);
    if (exp > 0) {
      sub_rows.push_back({r.label(), {s.value("received_in_time", 0.0) / exp, s.value("received_late", 0.0) / exp,
                                      s.value("lost", 0.0) / exp}});
    }
  }
  h << "<h2>Message categories (paper Fig. 11)</h2><p>Publisher: on time = written within its own period. Subscriber: "
       "in time = latency at most one period.</p>";
  h << svg::stacks("Publisher", {"sent on time", "sent late", "not sent"}, {"#2ca02c", "#ff7f0e", "#d62728"}, pub_rows);
  h << svg::stacks("Subscribers", {"received in time", "received late", "lost"}, {"#2ca02c", "#ff7f0e", "#d62728"}, sub_rows);

  // Fig. 14: fairness among subscribers.
  h << "<h2>Subscriber fairness (paper Fig. 14)</h2><p>Mean latency per subscriber node; the summary also has each "
       "node's mean delivery rank (0 = always first) and Jain's index.</p>";
  int shown = 0;
  for (const Run* r : heavy) {
    const auto& subs = r->s["per_subscriber"];
    if (subs.size() < 2 || shown >= 4) continue;
    ++shown;
    std::vector<std::string> labels;
    std::vector<double> vals;
    double hi = 0.001;
    for (const auto& sub : subs) {
      labels.push_back(std::to_string(sub.value("node", 0)));
      vals.push_back(sub["latency_ms"].value("mean", 0.0));
      hi = std::max(hi, vals.back());
    }
    h << svg::bars("Mean latency per subscriber - " + r->label() + " (Jain " +
                       fmt(3, r->s["fairness"].value("jain_mean_latency", 1.0)) + ")",
                   {0, hi * 1.2, false, "mean latency (ms)"}, labels, vals, kColors[2]);
  }
  if (shown == 0) h << "<p>No run with two or more subscriber nodes.</p>";

  // Floor: ddsperf results found below DIR.
  if (fs::is_directory(dir)) {
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (e.path().filename() != "ddsperf.json") continue;
      std::ifstream in(e.path());
      try {
        const auto d = json::parse(in);
        h << "<h2>Floor: Cyclone ddsperf ping/pong (" << svg::escape(d.value("transport", std::string())) << ")</h2><table>"
             "<tr><th>size</th><th>round trips</th><th>RTT mean ms</th><th>RTT p99</th><th>one-way est. mean</th></tr>";
        for (const auto& s : d["sizes"]) {
          if (!s.contains("rtt_ms")) continue;
          h << "<tr><td>" << s.value("size_label", std::string()) << "</td><td>" << s["roundtrips"] << "</td><td>"
            << fmt(3, s["rtt_ms"].value("mean", 0.0)) << "</td><td>" << fmt(3, s["rtt_ms"].value("p99", 0.0))
            << "</td><td>" << fmt(3, s["one_way_ms_est"].value("mean", 0.0)) << "</td></tr>";
        }
        h << "</table>";
      } catch (const std::exception&) {
        // not a ddsperf result
      }
    }
  }
  h << "</body></html>\n";

  res.html = (dir / "report.html").string();
  res.markdown = (dir / "report.md").string();
  std::ofstream(res.html) << h.str();
  std::ofstream(res.markdown) << "# rig perf: our figures beside the paper's\n\n" << markdown_table(sums);
  return res;
}

}  // namespace sensor_rig::bench::perf
