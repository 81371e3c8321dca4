#include "sensor_rig/bench/perf/stats.hpp"

#include <algorithm>
#include <cmath>

#include "sensor_rig/common/percentile.hpp"

namespace sensor_rig::bench::perf {

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
  s.p1 = interpolated_percentile(ms, 0.01);
  s.p25 = interpolated_percentile(ms, 0.25);
  s.p50 = interpolated_percentile(ms, 0.50);
  s.p75 = interpolated_percentile(ms, 0.75);
  s.p90 = interpolated_percentile(ms, 0.90);
  s.p99 = interpolated_percentile(ms, 0.99);
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
