#pragma once
// ClockMapper: device clock -> vehicle time (CLOCK_REALTIME ns) from (device, host receive) pairs.
// Pure estimator: no clock reads; every time is an argument. Algorithm in timesync/README.md:
// minimum-delay buckets over a sliding window, a trimmed lower-envelope (convex hull) line fit for
// offset + drift, outlier rejection, jump detection with quick re-lock, holdover.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

enum class SyncState : std::uint8_t {
  kUnsynced = 0,  // no usable samples (or holdover expired)
  kConverging,    // samples arrive; offset known, drift not yet trusted
  kLocked,        // offset and drift estimated over enough span
  kHoldover,      // no samples for holdover_after_ns: extrapolating the last fit
  kJumped,        // a device clock step was detected; re-locking with the previous drift
};
const char* to_string(SyncState s) noexcept;

struct ClockMapperConfig {
  Nanos bucket_ns = 100'000'000;          // device-time span of one minimum-delay bucket
  std::size_t window_buckets = 256;       // buckets kept for the fit (sliding window)
  std::size_t lock_buckets = 8;           // buckets needed to lock from cold
  Nanos lock_span_ns = 1'000'000'000;     // device-time span needed before drift is trusted
  std::size_t relock_buckets = 3;         // buckets needed to re-lock after a jump (drift kept)
  Nanos outlier_threshold_ns = 5'000'000; // |residual| beyond this: sample rejected (outlier)
  Nanos jump_threshold_ns = 10'000'000;   // |residual| beyond this: jump candidate
  std::size_t jump_confirm_samples = 3;   // consistent candidates needed to declare a jump
  Nanos jump_confirm_ns = 10'000'000;     // host-time span the candidates must cover
  Nanos reacquire_ns = 1'000'000'000;     // persistent shift between the two thresholds: re-seed
  // Arrivals later than the line by up to late_shift_max_ns are a held network (a switch, netem, a
  // busy NIC queue) as much as a device clock stepped back: one-way timing cannot tell the two apart,
  // only time can. Such a shift is taken for a step only once it has lasted late_confirm_ns (0: as
  // any other). Earlier arrivals (a step forward), bigger shifts (a reboot, an epoch change) and a
  // shift the host announced (host_step) confirm at once.
  Nanos late_confirm_ns = 3'000'000'000;
  Nanos late_shift_max_ns = 1'000'000'000;
  // A periodic device (a camera's frames) can tell them apart, though: across a held network its
  // device time advanced by whole periods while the arrivals jumped; across its clock stepped back
  // by S, by whole periods less S. With this set, a late shift most of whose first samples lie a
  // whole number of the device's periods (the median of the last 31 intervals between accepted
  // samples) after the last accepted one, and which is itself no whole number of periods (then the
  // two look alike), is a held network: never confirmed as a step while it lasts, however long (a
  // 26 s hold of a GigE camera's GVSP at 50 ms was taken for its clock stepped back after
  // late_confirm_ns: stamps 50 ms late, unflagged, until the hold ended). Off for streams whose
  // period is no cadence (LIDAR packets).
  bool cadence_tells_holds = false;
  double max_drift_ppm = 500.0;           // fits beyond this are rejected (drift kept)
  // A new drift is taken only where the floor is seen: >= 3 bucket minima within this of the line
  // on each side of the window's mean (sparse prompt arrivals fit hundreds of ppm; README item 2).
  Nanos slope_support_ns = 200'000;
  Nanos holdover_after_ns = 1'000'000'000;  // no sample for this long: holdover
  Nanos holdover_max_ns = 60'000'000'000;   // holdover beyond this: unsynced
  Nanos fixed_delay_ns = 0;               // known minimum transport delay, subtracted
  std::size_t residual_history = 256;     // accepted-sample residuals kept for p50/p99/std

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct MapResult {
  Nanos vehicle_ns = 0;
  SyncState state = SyncState::kUnsynced;
  bool valid = false;  // false only when there is no mapping (unsynced)
};

enum class ObserveResult : std::uint8_t {
  kAccepted = 0,
  kOutlier,        // rejected: residual beyond outlier_threshold_ns (kept as shift evidence)
  kJumpCandidate,  // beyond jump_threshold_ns; counts towards a jump
  kJumpDetected,   // this sample confirmed a jump; the mapping was re-seeded
  kRestarted,      // converging estimate was restarted (no jump counted)
  kStale,          // device time older than the window
};

struct ClockMapperStatus {
  SyncState state = SyncState::kUnsynced;
  Nanos offset_ns = 0;          // vehicle - device at the last sample's device time
  double drift_ppm = 0.0;       // device clock rate error; positive = device runs fast
  Nanos residual_p50_ns = 0;    // accepted samples: delay above the fitted envelope
  Nanos residual_p99_ns = 0;
  Nanos residual_std_ns = 0;
  Nanos fit_rms_ns = 0;         // rms of the bucket minima around the fitted line
  std::uint64_t samples = 0;    // observe() calls
  std::uint64_t accepted = 0;
  std::uint64_t outliers = 0;
  std::uint64_t stale = 0;
  std::uint64_t jumps = 0;
  std::uint64_t restarts = 0;
  std::uint64_t fit_rejects = 0;  // fits beyond max_drift_ppm
  Nanos last_jump_ns = 0;         // size of the last jump (new offset - old offset)
  Nanos last_device_ns = 0;       // last accepted sample
  Nanos last_host_ns = 0;         // last update (host time of the last accepted sample)
  std::size_t buckets = 0;
};

class ClockMapper {
 public:
  explicit ClockMapper(ClockMapperConfig cfg = {});  // throws std::invalid_argument

  ObserveResult observe(Nanos device_ns, Nanos host_ns) noexcept;

  // The host's CLOCK_REALTIME was stepped by step_ns (a RealtimeStepDetector saw it at host_now_ns,
  // after the step): every arrival from now on is step_ns later against the device, which is no
  // held network. Arrivals that shift by it confirm at the normal pace until late_confirm_ns after.
  void host_step(Nanos step_ns, Nanos host_now_ns) noexcept;

  // Vehicle time of a device time. State is kHoldover when device_ns is more than
  // holdover_after_ns past the last sample; invalid when unsynced or holdover expired.
  [[nodiscard]] MapResult map(Nanos device_ns) const noexcept;
  [[nodiscard]] std::optional<Nanos> to_vehicle(Nanos device_ns) const noexcept;

  // Status as of the last sample; the overload also applies holdover by host time now.
  [[nodiscard]] ClockMapperStatus status() const;
  [[nodiscard]] ClockMapperStatus status(Nanos host_now_ns) const;

  [[nodiscard]] SyncState state() const noexcept { return state_; }
  // Samples that disagree with the line by more than outlier_threshold_ns, consistently with each
  // other, and have not (yet) confirmed a jump: map() still uses the old line for them. shift_ns is
  // the first one's residual in (host - device): positive, the arrivals are later than the line
  // (a host delay, or the device clock stepped back); negative, earlier than the line allows (the
  // device clock stepped forward, or the line is late). samples == 0: none pending.
  // span_ns: host time the pending samples cover. awaiting_late: they would have confirmed a step
  // by the normal rule, but are later than the line (late_confirm_ns): a held network or a device
  // stepped back, not yet told apart; the line's stamps are as doubtful as the arrivals'.
  struct Deviation {
    std::size_t samples = 0;
    Nanos shift_ns = 0;
    Nanos span_ns = 0;
    bool awaiting_late = false;
  };
  [[nodiscard]] Deviation deviation() const noexcept;
  // How many of the newest `last` buckets have their minimum within tol_ns of the line (either
  // side), of how many there are: where the floor the line rests on was actually seen. The line is
  // the lower envelope of the arrivals, right only where some arrive with the transport's minimum
  // delay; a receiver held off at most frames (a loaded host, a thread below real-time work) puts
  // the envelope on the rare prompt frame, or on a late one when none came (timesync/README.md
  // "Floor support").
  struct FloorSupport {
    std::size_t seen = 0;
    std::size_t of = 0;
  };
  [[nodiscard]] FloorSupport floor_support(std::size_t last, Nanos tol_ns) const noexcept;
  [[nodiscard]] const ClockMapperConfig& config() const noexcept { return cfg_; }
  void reset() noexcept;  // back to unsynced; counters kept

 private:
  struct Bucket {
    std::int64_t index = 0;  // floor((device - origin) / bucket_ns)
    Nanos device_ns = 0;     // sample with the minimum y = host - device in this bucket
    Nanos y_ns = 0;
    std::uint32_t count = 0;
  };
  struct Candidate {
    Nanos device_ns = 0;
    Nanos host_ns = 0;
    Nanos y_ns = 0;
  };

  [[nodiscard]] double predict_y(Nanos device_ns) const noexcept;  // relative to anchor_y_
  [[nodiscard]] SyncState state_at_gap(Nanos gap_ns) const noexcept;
  void clear_window() noexcept;
  void seed(Nanos device_ns, Nanos host_ns, Nanos y_ns) noexcept;
  enum class BucketAdd : std::uint8_t { kNew, kUpdated, kStale };
  BucketAdd add_to_bucket(Nanos device_ns, Nanos y_ns) noexcept;
  void refit() noexcept;
  void update_lock_state(bool drift_fitted) noexcept;
  ObserveResult handle_deviation(Nanos device_ns, Nanos host_ns, Nanos y_ns, double resid) noexcept;
  void push_residual(double r) noexcept;
  [[nodiscard]] Nanos confirm_span_ns(double resid, Nanos host_ns) const noexcept;
  [[nodiscard]] bool is_late(double resid, Nanos host_ns) const noexcept;
  bool held_network(Nanos device_ns, double first_resid) noexcept;  // counts the sample's cadence
  void keep_candidate(const Candidate& c) noexcept;

  ClockMapperConfig cfg_;
  SyncState state_ = SyncState::kUnsynced;
  bool have_model_ = false;
  bool fit_valid_ = false;     // c_/s_ come from a fit of this window (warm start)
  bool drift_known_ = false;   // drift estimated at least once (kept across jumps)
  Nanos origin_ns_ = 0;        // device time of bucket index 0
  Nanos anchor_d_ = 0;         // model: y(d) = anchor_y_ + c_ + s_ * (d - anchor_d_)
  Nanos anchor_y_ = 0;
  double c_ = 0.0;
  double s_ = 0.0;
  double fit_rms_ = 0.0;
  std::vector<Bucket> buckets_;  // ring of window_buckets
  std::size_t head_ = 0;         // index of the oldest bucket
  std::size_t used_ = 0;
  std::vector<Candidate> candidates_;
  std::vector<Candidate> seeds_;
  std::vector<double> residuals_;  // ring of residual_history
  std::size_t res_head_ = 0;
  std::size_t res_used_ = 0;
  std::size_t buckets_since_seed_ = 0;
  Nanos first_device_ns_ = 0;  // since the last (re)seed, for lock span
  Nanos announced_step_ns_ = 0;      // host_step(): the shift arrivals will show (0: none)
  Nanos announced_until_ns_ = 0;     // host time after which the announcement is forgotten
  std::size_t skipped_ = 0;          // later-than-the-shift samples in a row (handle_deviation)
  static constexpr std::size_t kCadenceIntervals = 31;
  static constexpr double kCadenceVotePeriods = 5.5;  // late samples this near the last accepted one vote
  std::array<Nanos, kCadenceIntervals> intervals_{};  // device time between accepted samples, newest last (cadence_tells_holds)
  std::size_t interval_head_ = 0, interval_count_ = 0;
  bool held_network_ = false;        // the late samples since the last accepted one are a held network
  std::size_t cadence_whole_ = 0, cadence_other_ = 0;  // of those that voted: a whole number of periods on, or not
  ClockMapperStatus counters_;
  std::vector<double> scratch_x_, scratch_y_, scratch_r_;  // reused by refit, no allocation
  std::vector<unsigned char> mask_;
  std::vector<std::size_t> hull_;
};

}  // namespace sensor_rig::timesync
