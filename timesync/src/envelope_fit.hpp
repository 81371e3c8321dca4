#pragma once
// Private: fit a line to the lower envelope of (x, y) points with one-sided (positive) noise.
#include <cstddef>
#include <span>
#include <vector>

namespace sensor_rig::timesync::detail {

struct LineFit {
  double c = 0.0;    // y = c + s * x
  double s = 0.0;
  double rms = 0.0;  // rms of inlier residuals around the lowered line
  std::size_t inliers = 0;
};

// Robust lower-envelope line. Trimmed least squares (the prior slope when not free or x has no
// spread; warm-started from the previous line when given), iterated, drops points far above the line (beyond median + 3 robust sigma) or far below
// (median - 6 sigma); the inliers' lower convex hull edge at their mean x is then the line (with a
// fixed slope: the line through the lowest inlier). x ascending; x.size() == y.size() >= 1.
// The scratch vectors are resized as needed and reused between calls (no steady-state allocation).
struct FitOptions {
  bool free_slope = true;    // estimate the slope (else slope_prior is used)
  double slope_prior = 0.0;  // also the fallback when x has no spread
  bool start = false;        // trim against (start_c, start_s) first: the previous fit
  double start_c = 0.0;
  double start_s = 0.0;
};

LineFit fit_envelope(std::span<const double> x, std::span<const double> y, const FitOptions& o,
                     std::vector<double>& scratch, std::vector<unsigned char>& mask,
                     std::vector<std::size_t>& hull);

// q-quantile (0..1, lower interpolation point) of v; v is reordered. v must not be empty.
double quantile_inplace(std::span<double> v, double q);

}  // namespace sensor_rig::timesync::detail
