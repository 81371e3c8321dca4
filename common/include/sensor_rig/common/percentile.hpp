#pragma once
// Percentiles of sorted samples, the two conventions the rig uses. Pure; q is in [0, 1] (values
// outside are clamped, NaN counts as 0); no samples give 0.
//
// - nearest_rank_percentile: the sample at index round(q * (n - 1)) (halves round up): always one
//   of the samples. The monitor's latency stages and the DBW bridge's latency summary.
// - interpolated_percentile: linear interpolation between the two closest ranks at q * (n - 1)
//   (NumPy's default, R type 7). The paper evaluation (bench/perf).
#include <span>

namespace sensor_rig {

[[nodiscard]] double nearest_rank_percentile(std::span<const double> sorted, double q) noexcept;
[[nodiscard]] double interpolated_percentile(std::span<const double> sorted, double q) noexcept;

}  // namespace sensor_rig
