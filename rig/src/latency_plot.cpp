#include "latency_plot.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>

#include "sensor_rig/common/percentile.hpp"
#include "sensor_rig/common/svg.hpp"

namespace sensor_rig::rig {
namespace {

constexpr std::array<const char*, kStageCount> kStageColors = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd",
                                                               "#8c564b", "#e377c2", "#17becf", "#bcbd22"};

// When a sample happened, for the time axis: its acquisition, else its publish time.
Nanos when(const SampleRecord& r) { return r.acquisition_ns != 0 ? r.acquisition_ns : r.publish_ns; }

struct TopicSeries {
  std::array<svg::Series, kStageCount> stages;
  std::vector<double> lost_s;
};

// Log axis over the positive values: whole decades around them (latencies span µs to 100 ms).
svg::Axis log_axis(double lo, double hi, const std::string& label) {
  if (!(lo > 0) || !std::isfinite(lo)) lo = 1e-3;
  if (!(hi > lo) || !std::isfinite(hi)) hi = lo * 10;
  return {std::pow(10.0, std::floor(std::log10(lo))), std::pow(10.0, std::ceil(std::log10(hi * 1.0001))), true,
          label};
}

svg::Box box_of(std::vector<double> v, const std::string& label) {
  std::sort(v.begin(), v.end());
  svg::Box b;
  b.label = label + " (n=" + std::to_string(v.size()) + ")";
  b.p1 = nearest_rank_percentile(v, 0.01);
  b.p25 = nearest_rank_percentile(v, 0.25);
  b.p50 = nearest_rank_percentile(v, 0.50);
  b.p75 = nearest_rank_percentile(v, 0.75);
  b.p99 = nearest_rank_percentile(v, 0.99);
  b.max = v.back();
  b.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  return b;
}

}  // namespace

std::string latency_plot_svg(const std::vector<SampleRecord>& records) {
  if (records.empty()) return svg::document({});
  Nanos t0 = std::numeric_limits<Nanos>::max(), t1 = std::numeric_limits<Nanos>::min();
  for (const auto& r : records) {
    if (when(r) == 0) continue;
    t0 = std::min(t0, when(r));
    t1 = std::max(t1, when(r));
  }
  if (t0 > t1) t0 = t1 = 0;
  std::map<std::string, TopicSeries> topics;
  double lo = std::numeric_limits<double>::max(), hi = 0;
  for (const auto& r : records) {
    auto& t = topics[r.topic];
    const double x = static_cast<double>(when(r) - t0) * 1e-9;
    if (r.lost()) t.lost_s.push_back(x);
    const auto lat = stage_latencies_ms(r);
    for (std::size_t i = 0; i < kStageCount; ++i) {
      if (!lat[i] || !(*lat[i] > 0)) continue;  // a log axis: zero or negative (clock step) has no place
      t.stages[i].x.push_back(x);
      t.stages[i].y.push_back(*lat[i]);
      lo = std::min(lo, *lat[i]);
      hi = std::max(hi, *lat[i]);
    }
  }
  const svg::Axis y = log_axis(lo, hi, "latency (ms, log)");
  const svg::Axis x{0, std::max(1e-3, static_cast<double>(t1 - t0) * 1e-9), false, "time since first sample (s)"};
  std::vector<std::string> charts;
  for (auto& [name, t] : topics) {
    std::vector<svg::Series> series;
    std::vector<svg::Box> boxes;
    for (std::size_t i = 0; i < kStageCount; ++i) {
      if (t.stages[i].y.empty()) continue;
      t.stages[i].name = kStageNames[i];
      t.stages[i].color = kStageColors[i];
      boxes.push_back(box_of(t.stages[i].y, kStageNames[i]));
      series.push_back(std::move(t.stages[i]));
    }
    charts.push_back(svg::scatter(name + ": latency per stage", x, y, series, t.lost_s, "lost"));
    charts.push_back(svg::boxes(name + ": latency per stage (p1/p25/p50/p75/p99, max)", y, boxes));
  }
  return svg::document(charts);
}

void write_latency_plot(const std::string& path, const std::vector<SampleRecord>& records) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot create " + path);
  out << latency_plot_svg(records);
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace sensor_rig::rig
