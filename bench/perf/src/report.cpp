#include "sensor_rig/bench/perf/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "sensor_rig/bench/perf/records.hpp"
#include "svg.hpp"

namespace sensor_rig::bench::perf {
namespace fs = std::filesystem;
using nlohmann::json;
namespace {

const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

struct Run {
  fs::path dir;
  json s;
  [[nodiscard]] std::string label() const { return s.value("label", dir.filename().string()); }
};

std::vector<Run> find_runs(const fs::path& dir) {
  std::vector<Run> runs;
  auto load = [&](const fs::path& p) {
    std::ifstream in(p);
    try {
      runs.push_back({p.parent_path(), json::parse(in)});
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
  std::vector<SubRecord> all;
  for (const auto& e : fs::directory_iterator(r.dir)) {
    const auto n = e.path().filename().string();
    if (n.rfind("sub_", 0) == 0 && e.path().extension() == ".csv") {
      auto v = read_sub_csv(e.path().string());
      all.insert(all.end(), v.begin(), v.end());
    }
  }
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

}  // namespace

std::string paper_reference(const json& s) {
  const auto size = s.value("size", 0u);
  const int nodes = s.value("nodes", 0);
  const int topo = s.value("topology", 0);
  std::string ref;
  if (size == 1048576 && nodes == 32 && topo == 2) ref = "PointCloud1m to 31 subs: Cyclone 15-20 ms mean, Fast DDS 8 ms";
  else ref = "most latencies < 2 ms";
  if (size >= 524288 && nodes >= 8) ref += "; not all 600 sent on time (from 512 kB)";
  ref += "; loss up to 0.88 %";
  return ref;
}

std::string markdown_table(const std::vector<json>& summaries) {
  std::ostringstream o;
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
       "<th>lost</th><th>mean</th><th>p50</th><th>p90</th><th>p99</th><th>max</th><th>std</th><th>CPU s</th><th>max RSS MB</th><th>status</th></tr>";
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
    h << "<td>" << fmt(1, cpu) << "</td><td>" << fmt(0, rss) << "</td><td>"
      << (s["failed_nodes"].empty() ? "ok" : svg::escape(s["failed_nodes"].dump())) << "</td></tr>";
  }
  h << "</table>";

  // Fig. 8: latency over time, for the heaviest runs (at most 6).
  std::vector<const Run*> heavy;
  for (const auto& r : runs) heavy.push_back(&r);
  std::sort(heavy.begin(), heavy.end(), [](const Run* a, const Run* b) {
    return a->s.value("size", 0u) * a->s.value("received", 0ull) > b->s.value("size", 0u) * b->s.value("received", 0ull);
  });
  if (heavy.size() > 6) heavy.resize(6);
  h << "<h2>Latency over time (paper Fig. 8)</h2>";
  for (const Run* r : heavy) h << latency_over_time(*r);

  // Figs. 9-10: box plots per size and per subscriber count.
  if (!runs.empty()) {
    std::vector<svg::Box> b;
    double lo = 1e9, hi = 0;
    for (const auto& r : runs) {
      const auto& l = r.s["latency_ms"];
      if (l.value("n", 0) == 0) continue;
      b.push_back({r.label(), l.value("p1", 0.0), l.value("p25", 0.0), l.value("p50", 0.0), l.value("p75", 0.0),
                   l.value("p99", 0.0), l.value("max", 0.0), l.value("mean", 0.0)});
      lo = std::min(lo, std::max(1e-3, l.value("p1", 1.0)));
      hi = std::max(hi, l.value("max", 0.0));
    }
    if (!b.empty()) {
      h << "<h2>Latency distribution per size and subscriber count (paper Figs. 9-10)</h2>"
           "<p>Box p25-p75, red line median, whiskers p1-p99, circle max.</p>";
      const svg::Axis y{std::pow(10.0, std::floor(std::log10(lo))), hi * 1.2, true, "latency (ms, log)"};
      for (std::size_t i = 0; i < b.size(); i += 24) {
        std::vector<svg::Box> part(b.begin() + static_cast<long>(i), b.begin() + static_cast<long>(std::min(b.size(), i + 24)));
        h << svg::boxes("Latency per run", y, part);
      }
    }
  }

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
