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
  bool supported = true;  // false: the hull's slope lacked support on a side, the prior was kept
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
  // Points below the median are dropped only beyond max(6 sigma, low_trim): with sparse prompt
  // arrivals the floor itself lies 6 sigma of the late ones below their median (a camera frame
  // 2.8 ms more prompt than its neighbours was trimmed, its line 2.8 ms late); the caller admits
  // nothing farther below its line than its outlier threshold anyway.
  double low_trim = 0.0;
  double support = 0.0;      // > 0: a free slope needs inliers this close to it on both sides of the mean x
};

LineFit fit_envelope(std::span<const double> x, std::span<const double> y, const FitOptions& o,
                     std::vector<double>& scratch, std::vector<unsigned char>& mask,
                     std::vector<std::size_t>& hull);

// q-quantile (0..1, lower interpolation point) of v; v is reordered. v must not be empty.
double quantile_inplace(std::span<double> v, double q);

}  // namespace sensor_rig::timesync::detail
