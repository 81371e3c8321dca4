#include "sensor_rig/timesync/clock_mapper.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "envelope_fit.hpp"
#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::timesync {

namespace {
constexpr std::size_t kMaxCandidates = 256;

// a - b, saturated instead of overflowing (garbage device times must not be UB).
std::int64_t sat_sub(std::int64_t a, std::int64_t b) noexcept {
  std::int64_t r = 0;
  if (__builtin_sub_overflow(a, b, &r))
    return b < 0 ? std::numeric_limits<std::int64_t>::max() : std::numeric_limits<std::int64_t>::min();
  return r;
}

void require(bool ok, const char* field, const std::string& why) {
  if (!ok) throw std::invalid_argument(std::string("ClockMapperConfig.") + field + ": " + why);
}
}  // namespace

const char* to_string(SyncState s) noexcept {
  switch (s) {
    case SyncState::kUnsynced: return "unsynced";
    case SyncState::kConverging: return "converging";
    case SyncState::kLocked: return "locked";
    case SyncState::kHoldover: return "holdover";
    case SyncState::kJumped: return "jumped";
  }
  return "unknown";
}

void ClockMapperConfig::validate() const {
  require(bucket_ns > 0, "bucket_ns", "must be > 0");
  require(window_buckets >= 3 && window_buckets <= 4096, "window_buckets", "must be in 3..4096");
  require(lock_buckets >= 1 && lock_buckets <= window_buckets, "lock_buckets",
          "must be in 1..window_buckets");
  require(relock_buckets >= 1 && relock_buckets <= window_buckets, "relock_buckets",
          "must be in 1..window_buckets");
  require(lock_span_ns >= 0, "lock_span_ns", "must be >= 0");
  require(outlier_threshold_ns > 0, "outlier_threshold_ns", "must be > 0");
  require(jump_threshold_ns >= outlier_threshold_ns, "jump_threshold_ns",
          "must be >= outlier_threshold_ns");
  require(jump_confirm_samples >= 1 && jump_confirm_samples <= kMaxCandidates,
          "jump_confirm_samples", "must be in 1..256");
  require(jump_confirm_ns >= 0, "jump_confirm_ns", "must be >= 0");
  require(slope_support_ns >= 0, "slope_support_ns", "must be >= 0");
  require(max_drift_ppm > 0 && max_drift_ppm < 1e5, "max_drift_ppm", "must be in (0, 1e5)");
  require(holdover_after_ns > 0, "holdover_after_ns", "must be > 0");
  require(holdover_max_ns >= holdover_after_ns, "holdover_max_ns", "must be >= holdover_after_ns");
  require(fixed_delay_ns >= 0, "fixed_delay_ns", "must be >= 0");
  require(reacquire_ns >= jump_confirm_ns, "reacquire_ns", "must be >= jump_confirm_ns");
  require(late_confirm_ns >= 0, "late_confirm_ns", "must be >= 0");
  require(late_shift_max_ns >= 0, "late_shift_max_ns", "must be >= 0");
  require(residual_history >= 1 && residual_history <= 1'000'000, "residual_history",
          "must be in 1..1000000");
}

ClockMapper::ClockMapper(ClockMapperConfig cfg) : cfg_(cfg) {
  cfg_.validate();
  buckets_.resize(cfg_.window_buckets);
  candidates_.reserve(kMaxCandidates);
  seeds_.reserve(kMaxCandidates);
  residuals_.resize(cfg_.residual_history);
  scratch_x_.reserve(cfg_.window_buckets);
  scratch_y_.reserve(cfg_.window_buckets);
  scratch_r_.reserve(cfg_.window_buckets);
  mask_.reserve(cfg_.window_buckets);
  hull_.reserve(cfg_.window_buckets);
}

void ClockMapper::reset() noexcept {
  clear_window();
  have_model_ = false;
  drift_known_ = false;
  s_ = 0.0;
  c_ = 0.0;
  state_ = SyncState::kUnsynced;
  announced_step_ns_ = 0;
}

void ClockMapper::clear_window() noexcept {
  head_ = 0;
  used_ = 0;
  buckets_since_seed_ = 0;
  candidates_.clear();
}

double ClockMapper::predict_y(Nanos device_ns) const noexcept {
  return c_ + s_ * static_cast<double>(sat_sub(device_ns, anchor_d_));
}

void ClockMapper::seed(Nanos device_ns, Nanos host_ns, Nanos y_ns) noexcept {
  clear_window();
  origin_ns_ = device_ns;
  first_device_ns_ = device_ns;
  anchor_d_ = device_ns;
  anchor_y_ = y_ns;
  c_ = 0.0;  // slope kept: a device's crystal does not change when its clock is stepped
  have_model_ = true;
  fit_valid_ = false;  // a single seed sample is no line to warm-start from
  add_to_bucket(device_ns, y_ns);
  counters_.last_device_ns = device_ns;
  counters_.last_host_ns = host_ns;
}

ClockMapper::BucketAdd ClockMapper::add_to_bucket(Nanos device_ns, Nanos y_ns) noexcept {
  const std::int64_t idx = floor_div(sat_sub(device_ns, origin_ns_), cfg_.bucket_ns);
  const std::size_t cap = buckets_.size();
  if (used_ > 0) {
    Bucket& newest = buckets_[(head_ + used_ - 1) % cap];
    if (idx <= newest.index) {
      for (std::size_t k = used_; k-- > 0;) {
        Bucket& b = buckets_[(head_ + k) % cap];
        if (b.index == idx) {
          ++b.count;
          if (y_ns < b.y_ns) {
            b.y_ns = y_ns;
            b.device_ns = device_ns;
            if (state_ != SyncState::kLocked) refit();  // converging: every better minimum counts
          }
          return BucketAdd::kUpdated;
        }
        if (b.index < idx) break;
      }
      return BucketAdd::kStale;  // older than the window or in a hole between buckets
    }
  }
  if (used_ == cap) {
    head_ = (head_ + 1) % cap;
    --used_;
  }
  buckets_[(head_ + used_) % cap] = Bucket{idx, device_ns, y_ns, 1};
  ++used_;
  ++buckets_since_seed_;
  refit();
  return BucketAdd::kNew;
}

void ClockMapper::refit() noexcept {
  if (used_ == 0) return;
  const std::size_t cap = buckets_.size();
  const Bucket& oldest = buckets_[head_];
  const Bucket& newest = buckets_[(head_ + used_ - 1) % cap];
  scratch_x_.clear();
  scratch_y_.clear();
  for (std::size_t k = 0; k < used_; ++k) {
    const Bucket& b = buckets_[(head_ + k) % cap];
    scratch_x_.push_back(static_cast<double>(sat_sub(b.device_ns, oldest.device_ns)));
    scratch_y_.push_back(static_cast<double>(sat_sub(b.y_ns, oldest.y_ns)));
  }
  const bool free_slope = used_ >= 3 &&
                          sat_sub(newest.device_ns, oldest.device_ns) >= cfg_.lock_span_ns &&
                          sat_sub(newest.device_ns, first_device_ns_) >= cfg_.lock_span_ns;
  detail::FitOptions o;
  o.free_slope = free_slope;
  o.slope_prior = s_;
  o.support = static_cast<double>(cfg_.slope_support_ns);
  o.low_trim = static_cast<double>(cfg_.outlier_threshold_ns);
  if (fit_valid_) {  // the previous line in this window's coordinates
    o.start = true;
    o.start_s = s_;
    o.start_c = static_cast<double>(sat_sub(anchor_y_, oldest.y_ns)) + predict_y(oldest.device_ns);
  }
  detail::LineFit f = detail::fit_envelope(scratch_x_, scratch_y_, o, scratch_r_, mask_, hull_);
  if (free_slope) {
    const double ppm = -f.s / (1.0 + f.s) * 1e6;
    if (!(std::fabs(ppm) <= cfg_.max_drift_ppm)) {  // implausible rate: keep the previous one
      ++counters_.fit_rejects;
      o.free_slope = false;
      o.start = false;
      f = detail::fit_envelope(scratch_x_, scratch_y_, o, scratch_r_, mask_, hull_);
    } else {
      drift_known_ = true;  // fitted, or the prior kept for want of support: locked either way
    }
  }
  fit_valid_ = true;
  anchor_d_ = oldest.device_ns;
  anchor_y_ = oldest.y_ns;
  c_ = f.c;
  s_ = f.s;
  fit_rms_ = f.rms;
  update_lock_state(free_slope && drift_known_);
}

void ClockMapper::update_lock_state(bool drift_fitted) noexcept {
  // Converging locks once the drift is fitted over enough buckets; after a jump, once enough
  // buckets since the new seed confirm it.
  const bool converged = state_ == SyncState::kConverging && used_ >= cfg_.lock_buckets && drift_fitted;
  const bool relocked = state_ == SyncState::kJumped && buckets_since_seed_ >= cfg_.relock_buckets;
  if (converged || relocked) state_ = SyncState::kLocked;
}

void ClockMapper::push_residual(double r) noexcept {
  residuals_[res_head_] = r;
  res_head_ = (res_head_ + 1) % residuals_.size();
  res_used_ = std::min(res_used_ + 1, residuals_.size());
}

bool ClockMapper::is_late(double resid, Nanos host_ns) const noexcept {
  if (state_ == SyncState::kConverging) return false;  // a cold line is restarted, not defended
  if (!(resid > static_cast<double>(cfg_.outlier_threshold_ns)) || resid > static_cast<double>(cfg_.late_shift_max_ns))
    return false;
  const bool announced = announced_step_ns_ != 0 && host_ns <= announced_until_ns_ &&
                         std::fabs(resid - static_cast<double>(announced_step_ns_)) <=
                             static_cast<double>(cfg_.outlier_threshold_ns);
  return !announced;
}

Nanos ClockMapper::confirm_span_ns(double resid, Nanos host_ns) const noexcept {
  // A step beyond jump_threshold confirms quickly; a smaller persistent shift (the estimate was
  // wrong, or the device stepped by less) only after reacquire_ns of consistent samples.
  const Nanos span = std::fabs(resid) > static_cast<double>(cfg_.jump_threshold_ns) ? cfg_.jump_confirm_ns : cfg_.reacquire_ns;
  if (!is_late(resid, host_ns)) return span;
  return held_network_ ? std::numeric_limits<Nanos>::max() : std::max(span, cfg_.late_confirm_ns);
}

// Whether the late samples since the last accepted one are a held network (cadence_tells_holds):
// most of those within a few periods of it lie a whole number of periods (within an eighth of a
// period or outlier_threshold_ns) after it, and the shift is no whole number of periods. Only
// those near it vote: the period is an estimate, and k periods on its error is k times as large.
// Most, not the first: a device stamp may be a few ms off its grid (the GigE fakes restamp a frame
// their loaded thread began late; judged by the first late frame alone, 2 of 7 cameras of a
// campaign missed the hold).
bool ClockMapper::held_network(Nanos device_ns, double first_resid) noexcept {
  if (!cfg_.cadence_tells_holds || interval_count_ < 3 || !(first_resid > 0)) return false;
  // The period: the median of the recent intervals (a lost frame's double one, a late-begun
  // frame's short one do not move it; the shortest one did, by the lateness).
  std::array<Nanos, kCadenceIntervals> recent{};
  std::copy_n(intervals_.begin(), interval_count_, recent.begin());
  const auto mid = recent.begin() + static_cast<std::ptrdiff_t>(interval_count_ / 2);
  std::nth_element(recent.begin(), mid, recent.begin() + static_cast<std::ptrdiff_t>(interval_count_));
  const auto p = static_cast<double>(*mid);
  const double tol = std::min(p / 8, static_cast<double>(cfg_.outlier_threshold_ns));
  const auto whole = [&](double x) { return std::fabs(x - std::round(x / p) * p) <= tol; };
  const auto advanced = static_cast<double>(sat_sub(device_ns, counters_.last_device_ns));
  if (advanced <= kCadenceVotePeriods * p) ++(advanced >= p - tol && whole(advanced) ? cadence_whole_ : cadence_other_);
  return cadence_whole_ > cadence_other_ && !whole(first_resid);
}

void ClockMapper::keep_candidate(const Candidate& c) noexcept {
  skipped_ = 0;
  if (candidates_.size() == kMaxCandidates) {
    // A shift confirmed over seconds outlasts the buffer at LIDAR rates: thin it, keeping the first
    // sample (the span is measured from it) and an even spread for the re-seed.
    std::size_t kept = 1;
    for (std::size_t i = 2; i < candidates_.size(); i += 2) candidates_[kept++] = candidates_[i];
    candidates_.resize(kept);
  }
  candidates_.push_back(c);
}

void ClockMapper::host_step(Nanos step_ns, Nanos host_now_ns) noexcept {
  announced_step_ns_ = step_ns;
  Nanos until = 0;
  announced_until_ns_ = __builtin_add_overflow(host_now_ns, cfg_.late_confirm_ns, &until) ? host_now_ns : until;
}

ObserveResult ClockMapper::handle_deviation(Nanos device_ns, Nanos host_ns, Nanos y_ns,
                                            double resid) noexcept {
  double first_resid = resid;
  if (!candidates_.empty()) {
    const Candidate& first = candidates_.front();
    first_resid = static_cast<double>(sat_sub(first.y_ns, anchor_y_)) - predict_y(first.device_ns);
    const auto band = static_cast<double>(cfg_.outlier_threshold_ns);
    if (resid - first_resid > band && ++skipped_ < cfg_.jump_confirm_samples) {
      // Later than the shift by more than the band: that shift plus a queue (delays only add), no
      // evidence against it. Over a late span of seconds every network has such samples. Several
      // in a row say the first one was the odd one (an unusually prompt arrival): start again.
      ++counters_.outliers;
      return std::fabs(resid) > static_cast<double>(cfg_.jump_threshold_ns) ? ObserveResult::kJumpCandidate
                                                                             : ObserveResult::kOutlier;
    }
    if (std::fabs(first_resid - resid) > band) {  // earlier (the first sat in a queue), or that odd one
      candidates_.clear();
      first_resid = resid;
    }
  }
  held_network_ = held_network(device_ns, first_resid);
  keep_candidate(Candidate{device_ns, host_ns, y_ns});
  ++counters_.outliers;
  const bool big = std::fabs(resid) > static_cast<double>(cfg_.jump_threshold_ns);
  const Nanos span = sat_sub(candidates_.back().host_ns, candidates_.front().host_ns);
  if (candidates_.size() < cfg_.jump_confirm_samples || span < confirm_span_ns(first_resid, host_ns))
    return big ? ObserveResult::kJumpCandidate : ObserveResult::kOutlier;
  announced_step_ns_ = 0;  // whatever was announced has happened (or was not a shift of this device)

  // Confirmed: re-seed the window from the candidates, keeping the drift.
  const double old_pred = static_cast<double>(anchor_y_) + predict_y(device_ns);
  const bool was_converging = state_ == SyncState::kConverging;
  std::vector<Candidate>& seeds = seeds_;  // reserved: no allocation here
  seeds.assign(candidates_.begin(), candidates_.end());
  counters_.outliers -= seeds.size();
  seed(seeds.front().device_ns, seeds.front().host_ns, seeds.front().y_ns);
  state_ = was_converging ? SyncState::kConverging : SyncState::kJumped;
  counters_.accepted += 1;
  for (std::size_t i = 1; i < seeds.size(); ++i) {
    if (add_to_bucket(seeds[i].device_ns, seeds[i].y_ns) == BucketAdd::kStale)
      ++counters_.stale;
    else
      ++counters_.accepted;
  }
  refit();
  counters_.last_device_ns = device_ns;
  counters_.last_host_ns = host_ns;
  if (was_converging) {
    ++counters_.restarts;
    return ObserveResult::kRestarted;
  }
  ++counters_.jumps;
  // Size of the step in (vehicle - device): negative when the device clock stepped forward.
  const double new_pred = static_cast<double>(anchor_y_) + predict_y(device_ns);
  const double step = new_pred - old_pred;
  counters_.last_jump_ns = std::fabs(step) < 9e18 ? std::llround(step) : 0;
  return ObserveResult::kJumpDetected;
}

ObserveResult ClockMapper::observe(Nanos device_ns, Nanos host_ns) noexcept {
  ++counters_.samples;
  Nanos y_ns = 0;
  if (__builtin_sub_overflow(host_ns, device_ns, &y_ns)) {
    ++counters_.outliers;
    return ObserveResult::kOutlier;
  }
  if (!have_model_ || sat_sub(host_ns, counters_.last_host_ns) > cfg_.holdover_max_ns) {
    const bool restart = have_model_;
    seed(device_ns, host_ns, y_ns);
    state_ = SyncState::kConverging;
    ++counters_.accepted;
    push_residual(0.0);
    if (restart) {
      ++counters_.restarts;
      return ObserveResult::kRestarted;
    }
    return ObserveResult::kAccepted;
  }
  const double resid = static_cast<double>(sat_sub(y_ns, anchor_y_)) - predict_y(device_ns);
  const auto out = static_cast<double>(cfg_.outlier_threshold_ns);
  const auto jump = static_cast<double>(cfg_.jump_threshold_ns);
  // While converging the envelope is still forming: accept up to the jump threshold and let the
  // trimmed fit sort the samples out.
  const double limit = state_ == SyncState::kConverging ? jump : out;
  if (std::fabs(resid) > limit) return handle_deviation(device_ns, host_ns, y_ns, resid);
  candidates_.clear();
  held_network_ = false;  // a new late episode, if one comes, is judged afresh
  cadence_whole_ = cadence_other_ = 0;
  if (add_to_bucket(device_ns, y_ns) == BucketAdd::kStale) {
    ++counters_.stale;
    return ObserveResult::kStale;
  }
  push_residual(resid);
  ++counters_.accepted;
  if (const Nanos interval = sat_sub(device_ns, counters_.last_device_ns); cfg_.cadence_tells_holds && interval > 0) {
    intervals_[interval_head_] = interval;
    interval_head_ = (interval_head_ + 1) % intervals_.size();
    interval_count_ = std::min(interval_count_ + 1, intervals_.size());
  }
  counters_.last_device_ns = std::max(counters_.last_device_ns, device_ns);
  counters_.last_host_ns = std::max(counters_.last_host_ns, host_ns);
  return ObserveResult::kAccepted;
}

ClockMapper::FloorSupport ClockMapper::floor_support(std::size_t last, Nanos tol_ns) const noexcept {
  FloorSupport f;
  if (!have_model_) return f;
  const std::size_t cap = buckets_.size();
  const double tol = static_cast<double>(tol_ns);
  for (std::size_t k = used_; k-- > 0 && f.of < last;) {
    const Bucket& b = buckets_[(head_ + k) % cap];
    const double resid = static_cast<double>(sat_sub(b.y_ns, anchor_y_)) - predict_y(b.device_ns);
    ++f.of;
    if (std::fabs(resid) <= tol) ++f.seen;
  }
  return f;
}

ClockMapper::Deviation ClockMapper::deviation() const noexcept {
  if (candidates_.empty() || !have_model_) return {};
  const Candidate& first = candidates_.front();
  const Candidate& last = candidates_.back();
  const double resid = static_cast<double>(sat_sub(first.y_ns, anchor_y_)) - predict_y(first.device_ns);
  Deviation d;
  d.samples = candidates_.size();
  d.span_ns = sat_sub(last.host_ns, first.host_ns);
  if (!(std::fabs(resid) < 9e18)) {
    d.shift_ns = resid < 0 ? std::numeric_limits<Nanos>::min() : std::numeric_limits<Nanos>::max();
    return d;
  }
  d.shift_ns = std::llround(resid);
  const Nanos normal = std::fabs(resid) > static_cast<double>(cfg_.jump_threshold_ns) ? cfg_.jump_confirm_ns : cfg_.reacquire_ns;
  d.awaiting_late = d.samples >= cfg_.jump_confirm_samples && d.span_ns >= normal && is_late(resid, last.host_ns);
  return d;
}

SyncState ClockMapper::state_at_gap(Nanos gap_ns) const noexcept {
  if (!have_model_ || gap_ns > cfg_.holdover_max_ns) return SyncState::kUnsynced;
  if (gap_ns > cfg_.holdover_after_ns) return SyncState::kHoldover;
  return state_;
}

MapResult ClockMapper::map(Nanos device_ns) const noexcept {
  MapResult r;
  const Nanos gap = sat_sub(device_ns, counters_.last_device_ns);
  r.state = state_at_gap(gap);
  if (r.state == SyncState::kUnsynced) return r;
  const double corr = predict_y(device_ns);
  if (!(std::fabs(corr) < 9e18)) return MapResult{0, SyncState::kUnsynced, false};
  Nanos v = 0;
  if (__builtin_add_overflow(device_ns, anchor_y_, &v) ||
      __builtin_add_overflow(v, std::llround(corr) - cfg_.fixed_delay_ns, &v))
    return MapResult{0, SyncState::kUnsynced, false};
  r.vehicle_ns = v;
  r.valid = true;
  return r;
}

std::optional<Nanos> ClockMapper::to_vehicle(Nanos device_ns) const noexcept {
  const MapResult r = map(device_ns);
  if (!r.valid) return std::nullopt;
  return r.vehicle_ns;
}

ClockMapperStatus ClockMapper::status() const {
  ClockMapperStatus s = counters_;
  s.state = have_model_ ? state_ : SyncState::kUnsynced;
  s.buckets = used_;
  if (!have_model_) return s;
  s.offset_ns = anchor_y_ + std::llround(predict_y(counters_.last_device_ns)) - cfg_.fixed_delay_ns;
  s.drift_ppm = -s_ / (1.0 + s_) * 1e6;
  s.fit_rms_ns = std::llround(fit_rms_);
  if (res_used_ > 0) {
    std::vector<double> r(residuals_.begin(), residuals_.begin() + static_cast<std::ptrdiff_t>(res_used_));
    double sum = 0, sum2 = 0;
    for (double v : r) {
      sum += v;
      sum2 += v * v;
    }
    const double n = static_cast<double>(r.size());
    const double var = std::max(0.0, sum2 / n - (sum / n) * (sum / n));
    s.residual_std_ns = std::llround(std::sqrt(var));
    s.residual_p50_ns = std::llround(detail::quantile_inplace(r, 0.5));
    s.residual_p99_ns = std::llround(detail::quantile_inplace(r, 0.99));
  }
  return s;
}

ClockMapperStatus ClockMapper::status(Nanos host_now_ns) const {
  ClockMapperStatus s = status();
  if (have_model_) s.state = state_at_gap(sat_sub(host_now_ns, counters_.last_host_ns));
  return s;
}

}  // namespace sensor_rig::timesync
