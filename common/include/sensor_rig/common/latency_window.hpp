#pragma once
// Per-window latency samples for one stage, summarised as p50/p99/max (ms).
#include <algorithm>
#include <vector>

#include "sensor_rig/common/percentile.hpp"

namespace sensor_rig {

struct Percentiles {
  double p50 = 0, p99 = 0, max = 0;
  std::size_t n = 0;
};

class LatencyWindow {
 public:
  void add(double ms) { samples_.push_back(ms); }
  [[nodiscard]] bool empty() const { return samples_.empty(); }
  // Nearest-rank percentiles of the current window; clears it.
  Percentiles take() {
    Percentiles p;
    p.n = samples_.size();
    if (samples_.empty()) return p;
    std::sort(samples_.begin(), samples_.end());
    p.p50 = nearest_rank_percentile(samples_, 0.50);
    p.p99 = nearest_rank_percentile(samples_, 0.99);
    p.max = samples_.back();
    samples_.clear();
    return p;
  }

 private:
  std::vector<double> samples_;
};

}  // namespace sensor_rig
