#include "sensor_rig/common/percentile.hpp"

#include <cmath>
#include <cstddef>

namespace sensor_rig {
namespace {

// q * (n - 1), the fractional index of quantile q in n sorted samples (n > 0).
double position(std::size_t n, double q) noexcept {
  if (!(q > 0.0)) return 0.0;  // also NaN
  if (q > 1.0) q = 1.0;
  return q * static_cast<double>(n - 1);
}

}  // namespace

double nearest_rank_percentile(std::span<const double> sorted, double q) noexcept {
  if (sorted.empty()) return 0.0;
  // Halves round up, as the monitor and the bridge always did (std::lround agrees but for 0.5 - ulp).
  const auto i = static_cast<std::size_t>(position(sorted.size(), q) + 0.5);  // NOLINT(bugprone-incorrect-roundings)
  return sorted[i < sorted.size() ? i : sorted.size() - 1];
}

double interpolated_percentile(std::span<const double> sorted, double q) noexcept {
  if (sorted.empty()) return 0.0;
  const double pos = position(sorted.size(), q);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = lo + 1 < sorted.size() ? lo + 1 : sorted.size() - 1;
  const double frac = pos - static_cast<double>(lo);
  return sorted[lo] + (sorted[hi] - sorted[lo]) * frac;
}

}  // namespace sensor_rig
