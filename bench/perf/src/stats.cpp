#include "sensor_rig/bench/perf/stats.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::bench::perf {

double percentile_sorted(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, sorted.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  return sorted[lo] + (sorted[hi] - sorted[lo]) * frac;
}

LatencyStats compute_stats(std::vector<double>& ms) {
  LatencyStats s;
  s.n = ms.size();
  if (ms.empty()) return s;
  std::sort(ms.begin(), ms.end());
  double sum = 0;
  for (double v : ms) sum += v;
  s.mean = sum / static_cast<double>(ms.size());
  double sq = 0;
  for (double v : ms) sq += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(sq / static_cast<double>(ms.size()));
  s.min = ms.front();
  s.max = ms.back();
  s.p1 = percentile_sorted(ms, 0.01);
  s.p25 = percentile_sorted(ms, 0.25);
  s.p50 = percentile_sorted(ms, 0.50);
  s.p75 = percentile_sorted(ms, 0.75);
  s.p90 = percentile_sorted(ms, 0.90);
  s.p99 = percentile_sorted(ms, 0.99);
  return s;
}

double jain_index(const std::vector<double>& values) {
  if (values.empty()) return 1.0;
  double sum = 0, sq = 0;
  for (double v : values) {
    sum += v;
    sq += v * v;
  }
  if (sq == 0.0) return 1.0;
  return sum * sum / (static_cast<double>(values.size()) * sq);
}

}  // namespace sensor_rig::bench::perf
