#pragma once
// SweepPhase: where a spinning LIDAR looks, as a function of vehicle time, from (azimuth, time)
// samples of its own points; predicts when the sweep next crosses a given azimuth (to trigger a
// camera that looks there) and, afterwards, when it actually did (interpolated from the samples).
// Pure: no clock reads, no threads; every time is an argument. Algorithm in timesync/README.md.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

// One point of a sweep: its azimuth (degrees, any convention that turns with the sensor; the rig
// uses the LIDAR frame's REP 103 azimuth atan2(y, x)) and the vehicle time it was measured.
struct SweepSample {
  double azimuth_deg = 0.0;
  Nanos t_ns = 0;
};

// What the LIDAR driver is given to report its sweep (drivers/lidar calls it from its thread; an
// implementation that is read by another thread locks). No DDS, no ownership.
class SweepObserver {
 public:
  virtual ~SweepObserver() = default;
  virtual void observe_sweep(std::span<const SweepSample> samples) noexcept = 0;
};

struct SweepPhaseConfig {
  Nanos window_ns = 300'000'000;     // the line is fitted over the newest samples in this span
  Nanos history_ns = 600'000'000;    // samples kept for crossing_near() (>= window)
  Nanos stale_ns = 300'000'000;      // newest sample older than max(this, 2.5 periods): no prediction
  Nanos max_gap_ns = 2'000'000'000;  // a gap longer than this: the phase is re-acquired from scratch
  Nanos max_horizon_ns = 1'000'000'000;  // no prediction further than this past the newest sample
  double outlier_deg = 6.0;          // |residual| beyond this (vs the fit): outlier
  std::size_t restart_outliers = 24; // this many outliers in a row: rate or phase changed, re-seed
  std::size_t min_samples = 16;      // samples (and span) needed for a prediction
  Nanos min_span_ns = 30'000'000;
  double min_rate_hz = 1.0;          // |rotation rate| outside [min, max]: not locked
  double max_rate_hz = 40.0;
  double crossing_halfwidth_deg = 15.0;  // crossing_near(): samples within this turn angle of it
  std::size_t max_samples = 8192;    // memory bound (oldest dropped first)

  void validate() const;  // throws std::invalid_argument naming the bad field
};

enum class SweepState : std::uint8_t {
  kNoData = 0,  // nothing yet (or re-acquiring after a gap / restart)
  kConverging,  // samples, but not enough span or an implausible rate
  kLocked,      // rate and phase known: predictions are given
  kStale,       // the LIDAR stopped: no sample for the stale time, no prediction
};
const char* to_string(SweepState s) noexcept;

struct SweepStatus {
  SweepState state = SweepState::kNoData;
  double rate_hz = 0.0;            // turns per second, signed (negative: azimuth decreases)
  double residual_rms_deg = 0.0;   // of the inliers of the last fit
  std::uint64_t samples = 0;       // observed
  std::uint64_t accepted = 0;
  std::uint64_t outliers = 0;      // residual beyond outlier_deg (while locked)
  std::uint64_t reordered = 0;     // older than the newest accepted sample: ignored
  std::uint64_t gaps = 0;          // gaps beyond max_gap_ns (re-acquired)
  std::uint64_t restarts = 0;      // outlier runs that re-seeded the fit (rate/phase change)
  Nanos last_sample_ns = 0;
};

class SweepPhase {
 public:
  explicit SweepPhase(SweepPhaseConfig cfg = {});  // throws std::invalid_argument

  void observe(SweepSample s) noexcept;
  // A batch (e.g. one scan's samples, in time order): one fit at the end.
  void observe(std::span<const SweepSample> samples) noexcept;

  // The first time > after_ns at which the sweep crosses `azimuth_deg`, or none when not locked
  // or when the newest sample is stale at `now_ns` (the LIDAR stopped) or the crossing is beyond
  // the horizon.
  [[nodiscard]] std::optional<Nanos> next_crossing(double azimuth_deg, Nanos after_ns, Nanos now_ns) const noexcept;
  // When the sweep actually crossed `azimuth_deg` nearest `t_ns`, from the samples on both sides
  // (local line through them); none when they do not cover it (yet).
  [[nodiscard]] std::optional<Nanos> crossing_near(double azimuth_deg, Nanos t_ns) const noexcept;
  [[nodiscard]] SweepStatus status(Nanos now_ns) const noexcept;
  // Period of one turn (0 when unknown).
  [[nodiscard]] Nanos period_ns() const noexcept;
  void reset() noexcept;

 private:
  struct Point {
    Nanos t;
    double unwrapped_deg;  // continuous angle (turns add 360)
  };
  void accept(SweepSample s) noexcept;
  void refit() noexcept;
  void restart_from(SweepSample s) noexcept;
  [[nodiscard]] double fit_at(Nanos t) const noexcept { return fit_u0_ + fit_w_ * static_cast<double>(t - fit_t0_); }
  [[nodiscard]] bool locked_fit() const noexcept;

  SweepPhaseConfig cfg_;
  std::deque<Point> points_;
  bool have_fit_ = false;
  Nanos fit_t0_ = 0;
  double fit_u0_ = 0.0;
  double fit_w_ = 0.0;  // degrees per ns
  double fit_rms_ = 0.0;
  std::size_t fit_n_ = 0;
  Nanos fit_span_ = 0;
  std::size_t outlier_run_ = 0;
  std::uint64_t since_fit_ = 0;
  SweepStatus st_;
};

}  // namespace sensor_rig::timesync
