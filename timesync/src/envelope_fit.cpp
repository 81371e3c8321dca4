#include "envelope_fit.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::timesync::detail {

namespace {
constexpr int kIterations = 3;        // trim passes from cold
constexpr int kWarmIterations = 2;    // from the previous line: trim, refit, trim
constexpr double kUpperSigmas = 3.0;
constexpr double kLowerSigmas = 6.0;
constexpr double kScaleFloor = 2'000.0;  // ns: never trim tighter than this
constexpr double kMadToSigma = 1.4826;

// Least squares over the masked points; falls back to the given slope when x has no spread.
bool least_squares(std::span<const double> x, std::span<const double> y,
                   const std::vector<unsigned char>& mask, double& c, double& s) {
  double n = 0, sx = 0, sy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!mask[i]) continue;
    n += 1;
    sx += x[i];
    sy += y[i];
  }
  if (n < 2) return false;
  const double mx = sx / n, my = sy / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!mask[i]) continue;
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (!(sxx > 0)) return false;
  s = sxy / sxx;
  c = my - s * mx;
  return true;
}
// Lower convex hull (Andrew's monotone chain) of the masked points, x ascending; the edge whose x
// range contains `at` defines the line. False when the hull is a single x.
bool hull_edge_at(std::span<const double> x, std::span<const double> y,
                  const std::vector<unsigned char>& mask, double at, std::vector<std::size_t>& hull,
                  double& c, double& s) {
  hull.clear();
  const auto cross = [&](std::size_t o, std::size_t a, std::size_t b) {
    return (x[a] - x[o]) * (y[b] - y[o]) - (y[a] - y[o]) * (x[b] - x[o]);
  };
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!mask[i]) continue;
    if (!hull.empty() && x[i] <= x[hull.back()]) {  // equal (or unsorted) x: keep the lower one
      if (x[i] == x[hull.back()] && y[i] >= y[hull.back()]) continue;
      if (x[i] < x[hull.back()]) return false;  // caller must pass ascending x
      hull.pop_back();
    }
    while (hull.size() >= 2 && cross(hull[hull.size() - 2], hull.back(), i) <= 0) hull.pop_back();
    hull.push_back(i);
  }
  if (hull.size() < 2) return false;
  std::size_t k = 0;
  while (k + 2 < hull.size() && x[hull[k + 1]] < at) ++k;
  const std::size_t a = hull[k], b = hull[k + 1];
  s = (y[b] - y[a]) / (x[b] - x[a]);
  c = y[a] - s * x[a];
  return std::isfinite(s) && std::isfinite(c);
}

// The hull edge's slope rests on two points whose own delays it cannot see. With sparse prompt
// arrivals (a camera on a loaded host: 2 % of frames within 0.2 ms of the floor, the rest 2-8 ms
// late) the edge at the mean x joined a prompt frame to one 0.4-1.1 ms late, 1.5-4 s later, and
// read 280-294 ppm of drift from a clock with none: the stamps drifted 1.3-2 ms in seconds. A slope
// is a property of the floor only where the floor is seen: a new one is taken when at least
// kSupport inliers on each side of the mean x lie within `support` of its line; else the prior
// (the last slope taken, 0 from cold) is kept. A LIDAR's bucket minima, microseconds apart, support any fit at once.
void keep_prior_unless_supported(std::span<const double> x, std::span<const double> y, const std::vector<unsigned char>& mask,
                                 double mean_x, double prior, double support, LineFit& f) {
  constexpr std::size_t kSupport = 3;
  std::size_t left = 0, right = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!mask[i] || y[i] - (f.c + f.s * x[i]) > support) continue;
    ++(x[i] < mean_x ? left : right);
  }
  if (left >= kSupport && right >= kSupport) return;
  // The prior slope through the lowest point: below every point, as the one-sided noise wants (a
  // lone prompt frame is the floor: an impossible early one is its caller's to keep out).
  f.s = prior;
  f.supported = false;
  bool first = true;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!mask[i]) continue;
    const double c = y[i] - f.s * x[i];
    if (first || c < f.c) f.c = c;
    first = false;
  }
}

}  // namespace

double quantile_inplace(std::span<double> v, double q) {
  const auto k = static_cast<std::size_t>(std::floor(std::clamp(q, 0.0, 1.0) *
                                                     static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

LineFit fit_envelope(std::span<const double> x, std::span<const double> y, const FitOptions& o,
                     std::vector<double>& scratch, std::vector<unsigned char>& mask,
                     std::vector<std::size_t>& hull) {
  const std::size_t n = x.size();
  const bool free_slope = o.free_slope;
  const double slope_prior = o.slope_prior;
  mask.assign(n, 1);
  scratch.resize(n);
  LineFit f;
  const int passes = o.start ? kWarmIterations : kIterations;
  double sigma = kScaleFloor;
  for (int it = 0; it < passes; ++it) {
    if (it == 0 && o.start) {  // warm start: trim against the previous line first
      f.c = o.start_c;
      f.s = o.start_s;
    } else if (!free_slope || !least_squares(x, y, mask, f.c, f.s)) {
      f.s = slope_prior;
      f.c = 0.0;  // the residual median below sets the level
    }
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (mask[i]) scratch[m++] = y[i] - (f.c + f.s * x[i]);
    if (m == 0) break;
    const double med = quantile_inplace(std::span(scratch.data(), m), 0.5);
    if (it == 0) {  // the scale from the first pass serves the later ones (selection is the cost)
      for (std::size_t i = 0; i < m; ++i) scratch[i] = std::fabs(scratch[i] - med);
      sigma = std::max(kMadToSigma * quantile_inplace(std::span(scratch.data(), m), 0.5), kScaleFloor);
    }
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      const double r = y[i] - (f.c + f.s * x[i]) - med;
      const unsigned char keep = (r <= kUpperSigmas * sigma && r >= -std::max(kLowerSigmas * sigma, o.low_trim)) ? 1 : 0;
      changed = changed || keep != mask[i];
      mask[i] = keep;
    }
    if (!changed) break;
  }
  // The lower envelope of the inliers: the LP "line below every point, as high as possible at the
  // mean x" is the lower convex hull edge that spans the mean x (one-sided delay noise).
  f.inliers = 0;
  double sum_x = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!mask[i]) continue;
    ++f.inliers;
    sum_x += x[i];
  }
  if (f.inliers == 0) {  // cannot happen with the median rule; stay defined anyway
    mask.assign(n, 1);
    f.inliers = n;
    for (std::size_t i = 0; i < n; ++i) sum_x += x[i];
  }
  bool hull_ok = false;
  if (free_slope) {
    const double mean_x = sum_x / static_cast<double>(f.inliers);
    hull_ok = hull_edge_at(x, y, mask, mean_x, hull, f.c, f.s);
    if (hull_ok && o.support > 0) keep_prior_unless_supported(x, y, mask, mean_x, slope_prior, o.support, f);
  }
  if (!hull_ok) {
    if (!free_slope || f.inliers < 2) f.s = slope_prior;
    double lowest = 0;
    bool first = true;
    for (std::size_t i = 0; i < n; ++i) {
      if (!mask[i]) continue;
      const double r = y[i] - f.s * x[i];
      if (first || r < lowest) lowest = r;
      first = false;
    }
    f.c = lowest;
  }
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!mask[i]) continue;
    const double r = y[i] - (f.c + f.s * x[i]);
    ss += r * r;
  }
  f.rms = std::sqrt(ss / static_cast<double>(f.inliers));
  return f;
}

}  // namespace sensor_rig::timesync::detail
