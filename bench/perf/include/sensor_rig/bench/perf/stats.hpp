#pragma once
// Latency statistics over a set of samples (ms). Pure.
#include <vector>

namespace sensor_rig::bench::perf {

struct LatencyStats {
  std::size_t n = 0;
  double mean = 0, std = 0, min = 0, p1 = 0, p25 = 0, p50 = 0, p75 = 0, p90 = 0, p99 = 0, max = 0;
};

// Sorts `ms` in place. Percentiles by linear interpolation between closest ranks
// (interpolated_percentile, sensor_rig/common/percentile.hpp); std is the population standard
// deviation. Empty input gives all zeros with n = 0.
LatencyStats compute_stats(std::vector<double>& ms);

// Jain's fairness index of non-negative values: 1 = all equal, 1/n = one takes all. 1 for empty input.
double jain_index(const std::vector<double>& values);

}  // namespace sensor_rig::bench::perf
