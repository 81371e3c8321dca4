#include "sensor_rig/timesync/sweep_phase.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>

namespace sensor_rig::timesync {
namespace {
// Older than the newest sample by more than this is a clock step back, not reordering (which
// is within a batch of packets).
constexpr Nanos kClockStepBackNs = 250'000'000;
}  // namespace
namespace {

double wrap360(double a) noexcept {
  const double r = std::fmod(a, 360.0);
  return r < 0 ? r + 360.0 : r;
}

// Least squares y = a + b x over (x, y); false when x has no spread.
struct Line {
  double a = 0, b = 0;
};
template <class It, class Fx, class Fy>
bool least_squares(It first, It last, Fx fx, Fy fy, Line& out) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (It it = first; it != last; ++it) {
    const double x = fx(*it), y = fy(*it);
    n += 1;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double den = n * sxx - sx * sx;
  if (n < 2 || den <= 0) return false;
  out.b = (n * sxy - sx * sy) / den;
  out.a = (sy - out.b * sx) / n;
  return true;
}

}  // namespace

void SweepPhaseConfig::validate() const {
  const auto bad = [](const char* f) { throw std::invalid_argument(std::string("SweepPhaseConfig: bad ") + f); };
  if (window_ns <= 0) bad("window_ns");
  if (history_ns < window_ns) bad("history_ns (must be >= window_ns)");
  if (stale_ns <= 0) bad("stale_ns");
  if (max_gap_ns <= 0) bad("max_gap_ns");
  if (max_horizon_ns <= 0) bad("max_horizon_ns");
  if (!(outlier_deg > 0 && outlier_deg < 90)) bad("outlier_deg");
  if (restart_outliers == 0) bad("restart_outliers");
  if (min_samples < 2) bad("min_samples");
  if (!(min_rate_hz > 0 && max_rate_hz > min_rate_hz)) bad("min_rate_hz/max_rate_hz");
  if (!(crossing_halfwidth_deg > 0 && crossing_halfwidth_deg < 90)) bad("crossing_halfwidth_deg");
  if (max_samples < min_samples) bad("max_samples");
}

const char* to_string(SweepState s) noexcept {
  switch (s) {
    case SweepState::kNoData: return "no_data";
    case SweepState::kConverging: return "converging";
    case SweepState::kLocked: return "locked";
    case SweepState::kStale: return "stale";
  }
  return "?";
}

SweepPhase::SweepPhase(SweepPhaseConfig cfg) : cfg_(cfg) { cfg_.validate(); }

void SweepPhase::reset() noexcept {
  points_.clear();
  have_fit_ = false;
  outlier_run_ = 0;
  since_fit_ = 0;
  st_ = {};
}

void SweepPhase::restart_from(SweepSample s) noexcept {
  points_.clear();
  have_fit_ = false;
  outlier_run_ = 0;
  points_.push_back({s.t_ns, wrap360(s.azimuth_deg)});
  ++st_.accepted;
  st_.last_sample_ns = s.t_ns;
}

bool SweepPhase::locked_fit() const noexcept {
  if (!have_fit_ || fit_n_ < cfg_.min_samples || fit_span_ < cfg_.min_span_ns || fit_rms_ >= cfg_.outlier_deg) return false;
  const double hz = std::abs(fit_w_) * 1e9 / 360.0;
  return hz >= cfg_.min_rate_hz && hz <= cfg_.max_rate_hz;
}

void SweepPhase::accept(SweepSample s) noexcept {
  ++st_.samples;
  if (!std::isfinite(s.azimuth_deg)) {
    ++st_.outliers;
    return;
  }
  if (points_.empty()) {
    restart_from(s);
    return;
  }
  const Point& last = points_.back();
  if (s.t_ns < last.t - 1'000'000) {  // simultaneous lasers share a time; older than that is reordered
    // Far older: the clock the samples are stamped in stepped back (a host-time LIDAR, a
    // CLOCK_REALTIME step). Dropping every sample until time caught up left the triggered cameras
    // without a prediction for the step's length (issue 27 item 11): the phase starts again here.
    if (last.t - s.t_ns > kClockStepBackNs) {
      ++st_.gaps;
      restart_from(s);
      return;
    }
    ++st_.reordered;
    return;
  }
  if (s.t_ns - last.t > cfg_.max_gap_ns) {  // too long to know how many turns were missed
    ++st_.gaps;
    restart_from(s);
    return;
  }
  // Unwrap against the fitted line where it is trustworthy (any gap), else against the last sample.
  const bool locked = locked_fit();
  const double ref = locked ? fit_at(s.t_ns) : last.unwrapped_deg;
  const double u = s.azimuth_deg + 360.0 * std::round((ref - s.azimuth_deg) / 360.0);
  if (locked && std::abs(u - ref) > cfg_.outlier_deg) {
    ++st_.outliers;
    if (++outlier_run_ >= cfg_.restart_outliers) {  // not noise: the rotation changed
      ++st_.restarts;
      restart_from(s);
    }
    return;
  }
  outlier_run_ = 0;
  points_.push_back({s.t_ns, u});
  ++st_.accepted;
  ++since_fit_;
  st_.last_sample_ns = std::max(st_.last_sample_ns, s.t_ns);
  while (!points_.empty() && (points_.front().t < s.t_ns - cfg_.history_ns || points_.size() > cfg_.max_samples))
    points_.pop_front();
}

void SweepPhase::observe(SweepSample s) noexcept {
  accept(s);
  // Single samples: refit every few, and at once while there is no fit.
  if (since_fit_ >= 16 || (!have_fit_ && points_.size() >= 2)) refit();
}

void SweepPhase::observe(std::span<const SweepSample> samples) noexcept {
  for (const auto& s : samples) {
    accept(s);
    if (!have_fit_ && points_.size() >= cfg_.min_samples) refit();  // unwrap the rest against a line
  }
  if (since_fit_ > 0) refit();
}

void SweepPhase::refit() noexcept {
  since_fit_ = 0;
  if (points_.size() < 2) {
    have_fit_ = false;
    return;
  }
  const Nanos t0 = points_.back().t;
  const double u_ref = points_.back().unwrapped_deg;
  auto first = std::lower_bound(points_.begin(), points_.end(), t0 - cfg_.window_ns,
                                [](const Point& p, Nanos t) { return p.t < t; });
  if (std::distance(first, points_.end()) < 2) first = points_.end() - 2;
  const auto fx = [t0](const Point& p) { return static_cast<double>(p.t - t0); };
  const auto fy = [u_ref](const Point& p) { return p.unwrapped_deg - u_ref; };
  Line l;
  if (!least_squares(first, points_.end(), fx, fy, l)) {
    have_fit_ = false;
    return;
  }
  // One trimming pass: samples beyond the outlier band of the first line do not pull the second.
  std::size_t n = 0;
  double ss = 0;
  Nanos oldest = t0;
  Line trimmed;
  {
    double sn = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (auto it = first; it != points_.end(); ++it) {
      const double x = fx(*it), y = fy(*it);
      if (std::abs(y - (l.a + l.b * x)) > cfg_.outlier_deg) continue;
      sn += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    const double den = sn * sxx - sx * sx;
    if (sn >= 2 && den > 0) {
      trimmed.b = (sn * sxy - sx * sy) / den;
      trimmed.a = (sy - trimmed.b * sx) / sn;
    } else {
      trimmed = l;
    }
  }
  for (auto it = first; it != points_.end(); ++it) {
    const double r = fy(*it) - (trimmed.a + trimmed.b * fx(*it));
    if (std::abs(r) > cfg_.outlier_deg) continue;
    ++n;
    ss += r * r;
    oldest = std::min(oldest, it->t);
  }
  have_fit_ = true;
  fit_t0_ = t0;
  fit_u0_ = u_ref + trimmed.a;
  fit_w_ = trimmed.b;
  fit_n_ = n;
  fit_rms_ = n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
  fit_span_ = t0 - oldest;
}

Nanos SweepPhase::period_ns() const noexcept {
  if (!locked_fit()) return 0;
  return static_cast<Nanos>(std::llround(360.0 / std::abs(fit_w_)));
}

std::optional<Nanos> SweepPhase::next_crossing(double azimuth_deg, Nanos after_ns, Nanos now_ns) const noexcept {
  if (!locked_fit() || points_.empty() || !std::isfinite(azimuth_deg)) return std::nullopt;
  const Nanos newest = points_.back().t;
  const Nanos stale = std::max(cfg_.stale_ns, static_cast<Nanos>(2.5 * static_cast<double>(period_ns())));
  if (now_ns - newest > stale) return std::nullopt;
  const double a = wrap360(azimuth_deg);
  const double u_after = fit_at(after_ns);
  const double target = fit_w_ > 0 ? a + 360.0 * (std::floor((u_after - a) / 360.0) + 1.0)
                                   : a + 360.0 * (std::ceil((u_after - a) / 360.0) - 1.0);
  const Nanos t = fit_t0_ + static_cast<Nanos>(std::llround((target - fit_u0_) / fit_w_));
  if (t - newest > cfg_.max_horizon_ns) return std::nullopt;
  return std::max(t, after_ns + 1);
}

std::optional<Nanos> SweepPhase::crossing_near(double azimuth_deg, Nanos t_ns) const noexcept {
  if (!have_fit_ || points_.size() < 6 || !std::isfinite(azimuth_deg)) return std::nullopt;
  // An implausible rate (a fit from a few samples) would put the crossing anywhere, even past Nanos.
  const double hz = std::abs(fit_w_) * 1e9 / 360.0;
  if (!(hz >= cfg_.min_rate_hz && hz <= cfg_.max_rate_hz)) return std::nullopt;
  const double a = wrap360(azimuth_deg);
  const double target = a + 360.0 * std::round((fit_at(t_ns) - a) / 360.0);
  // Where the fitted line says the crossing was; the samples around it (chosen by time, which is
  // exact, not by azimuth, which carries the per-laser scatter) then give it locally: each sample
  // says "target was reached (target - u) / w after me", averaged.
  const Nanos t_est = fit_t0_ + static_cast<Nanos>(std::llround((target - fit_u0_) / fit_w_));
  const Nanos half = static_cast<Nanos>(cfg_.crossing_halfwidth_deg / std::abs(fit_w_));
  std::size_t before = 0, after = 0;
  double sum = 0;
  for (const auto& p : points_) {
    if (p.t < t_est - half || p.t > t_est + half) continue;
    (p.t < t_est ? before : after)++;
    sum += static_cast<double>(p.t - t_est) + (target - p.unwrapped_deg) / fit_w_;
  }
  // Both sides covered, each by a few samples: an interpolation, never an extrapolation.
  if (before < 3 || after < 3) return std::nullopt;
  return t_est + static_cast<Nanos>(std::llround(sum / static_cast<double>(before + after)));
}

SweepStatus SweepPhase::status(Nanos now_ns) const noexcept {
  SweepStatus s = st_;
  s.rate_hz = have_fit_ ? fit_w_ * 1e9 / 360.0 : 0.0;
  s.residual_rms_deg = have_fit_ ? fit_rms_ : 0.0;
  if (points_.empty()) {
    s.state = SweepState::kNoData;
  } else {
    const Nanos stale = std::max(cfg_.stale_ns, static_cast<Nanos>(2.5 * static_cast<double>(period_ns())));
    if (now_ns - points_.back().t > stale) {
      s.state = SweepState::kStale;
    } else {
      s.state = locked_fit() ? SweepState::kLocked : SweepState::kConverging;
    }
  }
  return s;
}

}  // namespace sensor_rig::timesync
