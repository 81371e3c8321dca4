#include "sensor_rig/drivers/camera/frame_clock.hpp"

#include <algorithm>
#include <cstdlib>

namespace sensor_rig::drivers {
namespace {

// How far before its trigger tick a mapped exposure start may fall (the mapping's error).
constexpr Nanos kMappedExposureSlackNs = 5'000'000;
// A frame's first packet leaves at its exposure end; transport and a loaded host delay its arrival
// (a stalled fake by up to ~0.3 s in the campaigns), never by this much: an exposure start further
// back is a clock error (a 37 s TAI offset, a camera clock from 1970).
constexpr Nanos kArrivalWindowNs = 1'000'000'000;
// A frame arriving later than its locked line by more than this was held (trigger_reference).
constexpr Nanos kHeldBeyondNs = 20'000'000;

constexpr std::size_t kMaxPending = 8;

// Consecutive samples later than the line by a consistent amount before the line is distrusted:
// one or two late frames are a host hiccup (the mapped stamp is right, the arrival is not); more,
// and a device clock stepped back is as likely (the mapped stamp would be the step off): refused,
// or, for a late shift the mapper defends (doubt() below), kept and flagged.
constexpr std::size_t kStepSamples = 3;

// A step of a PTP camera's raw ticks beyond this is no servo correction (the mapper's jump threshold).
constexpr Nanos kPtpStepNs = 10'000'000;

// The mapper is fed the exposure start by the arrival (first packet - exposure), so its line does
// not depend on the exposure: one that changes while streaming changes what is subtracted per
// frame, not the fit (issue 27 item 9).
timesync::ClockMapperConfig mapper_config(Nanos /*exposure_ns*/) {
  timesync::ClockMapperConfig c;
  c.fixed_delay_ns = 0;
  // A frame every 33-100 ms: buckets of 200 ms keep a few samples each for the minimum. (1 s
  // buckets locked later and no better: replayed on three campaigns' records, 6 frames beyond
  // 1 ms against 2-3.)
  c.bucket_ns = 200'000'000;
  c.lock_buckets = 5;
  // A jump (or a persistent shift) is confirmed over 1 s of frames, not 3 of them: a host or fake
  // hiccup delays a few frames by tens of ms in a row, and a line re-seeded from them was 2-6 ms
  // off until the next hiccup. A real step (PTP state, cold start) is mapped with the old line
  // meanwhile, which the arrival window below catches when it is large.
  c.jump_confirm_samples = 10;
  c.jump_confirm_ns = 1'000'000'000;
  c.reacquire_ns = 5'000'000'000;
  // late_confirm_ns / late_shift_max_ns: the mapper's defaults (3 s / 1 s), as the LIDARs'. Arrivals
  // later than the line are a held network (host.network_delay: GVSP 50 ms late for seconds) as much
  // as a clock stepped back. Before, late_confirm_ns was 0 and such a shift refused the line after 3
  // frames and was confirmed after 1 s: a held camera's stamps followed its arrivals (campaign: held
  // frames p50 +50.2 ms, none flagged), though a late arrival does not move an exposure. Now the line
  // stays for 3 s, its stamps kept and flagged (doubt() below); a real step back up to 1 s is mapped
  // that step off, flagged, for 3 s. Worth it: a free-running camera's ticks step back only when it
  // restarts (by far more than 1 s: refused at once as before), a PTP camera's come with a lock
  // change (refused as before, doubt()), while a held network is what a car's switch does.
  // And a hold longer than late_confirm_ns is told by the frames' cadence, not by time: across it
  // the camera's ticks advance by whole frame periods (timesync/README.md item 5).
  c.cadence_tells_holds = true;
  return c;
}

// Floor support (ClockMapper::floor_support): of the newest kFloorBuckets buckets (5 s of 200 ms
// at 10 Hz), at least half, and three, must hold a frame that arrived within kFloorToleranceNs of
// the line. Measured on the whole mock rig's campaign (seed 25, 4 + 3 runs): a free-running GigE
// camera whose Aravis thread runs at SCHED_FIFO saw its floor in 23-25 of every 25 buckets; at normal
// priority beside the rig's real-time threads its leaders were taken p50 3.5-5 ms late and the floor
// was seen in 0-2 of 25, once in none for the first 5 s: the line 1.24 ms late, said locked. Half,
// not a fifth: frames all 2-10 ms late (none prompt) put their floor near 2 ms, "seen" in 2 of 25
// buckets on average and in 5 often enough to publish 2 ms errors unflagged (test_frame_clock.cpp
// ALineOnAFloorFewFramesSawIsFlagged); in 13 never.
constexpr std::size_t kFloorBuckets = 25;
constexpr Nanos kFloorToleranceNs = 300'000;

bool floor_seen(const timesync::ClockMapper::FloorSupport& f) noexcept {
  return f.seen >= std::max<std::size_t>(3, (f.of + 1) / 2);
}

}  // namespace

const char* to_string(StampSource s) noexcept {
  switch (s) {
    case StampSource::kDeviceMapped: return "device_mapped";
    case StampSource::kHostFallback: return "host_fallback";
    case StampSource::kMonotonic: return "monotonic";
    case StampSource::kVehicle: return "device_vehicle";
    case StampSource::kTriggerTick: return "trigger_tick";
    case StampSource::kTriggerExposure: return "trigger_exposure";
  }
  return "?";
}

FrameClock::FrameClock(Nanos exposure_ns) : mapper_(mapper_config(exposure_ns)), exposure_ns_(exposure_ns) {}

void FrameClock::reset(Nanos exposure_ns) {
  mapper_ = timesync::ClockMapper(mapper_config(exposure_ns));
  exposure_ns_ = exposure_ns;
  pending_.clear();
  exposures_reported_ = false;
  announced_step_ns_ = 0;  // the new mapper converges from scratch: no line a step could shift
  have_domain_ = false;
  ptp_changed_at_ns_ = 0;
  floor_ = {};
}

bool FrameClock::ptp_changed_recently(Nanos now) const noexcept {
  return ptp_changed_at_ns_ != 0 && now - ptp_changed_at_ns_ <= mapper_.config().late_confirm_ns;
}

void FrameClock::announce_ptp_step(Nanos now) noexcept {
  if (!ptp_changed_recently(now)) return;
  const auto d = mapper_.deviation();
  if (d.samples == 0 || d.shift_ns <= 0 || d.shift_ns == announced_step_ns_) return;
  mapper_.host_step(d.shift_ns, now);
  announced_step_ns_ = d.shift_ns;
  announced_at_ns_ = now;
}

FrameClock::Doubt FrameClock::doubt(const timesync::ClockMapper::Deviation& d, Nanos now) const noexcept {
  if (d.samples == 0) return {};
  // Earlier than the line allows: no network delivers before the send; the device clock stepped
  // forward (or CLOCK_REALTIME back): the line's stamps are refused at once.
  if (d.shift_ns < 0) return {true, false};
  const auto& cfg = mapper_.config();
  // The mapper's own rule (ClockMapper::is_late, timesync/README.md item 5): a late shift up to
  // late_shift_max_ns waits late_confirm_ns unless the line is still converging (restarted, not
  // defended) or the host announced it (a CLOCK_REALTIME step forward of that size: the arrivals
  // moved, not the exposures; the line's stamps are the step early, refused as before).
  const bool announced = announced_step_ns_ != 0 && now - announced_at_ns_ <= cfg.late_confirm_ns &&
                         std::llabs(d.shift_ns - announced_step_ns_) <= cfg.outlier_threshold_ns;
  // Nor a late shift near a PTP lock change: the camera's clock took its (new) master's time, or
  // ran free: a step is what that does, a held network does not come with it.
  const bool defended = cfg.late_confirm_ns > 0 && mapper_.state() != timesync::SyncState::kConverging &&
                        d.shift_ns <= cfg.late_shift_max_ns && !announced && !ptp_changed_recently(now);
  if (!defended) return {d.samples >= kStepSamples, false};
  // A held network or a clock stepped back: only time tells. The line's stamp is the exposure of a
  // held frame (refusing it stamped the arrival: +50 ms under a 50 ms hold) and the step off for a
  // clock stepped back: kept, flagged once kStepSamples agree (one or two are a host hiccup).
  return {false, d.samples >= kStepSamples};
}

void FrameClock::observe(const camera::FrameMeta& m, Nanos device) noexcept {
  if (m.exposure_seq == 0 || m.exposure_ns <= 0) {  // no per-frame exposure: the one known now
    mapper_.observe(device, m.first_rx_ns - exposure_ns_);
    return;
  }
  if (!exposures_reported_ && m.exposure_ns != exposure_ns_) {
    // The first exposure the source tells (a frame after the first, read after it) is not the one
    // the frames before were observed with: they arrived that much earlier or later than the
    // mapper was told. Too early is an impossible prompt sample, which the mapper rightly takes
    // for the floor (auto exposure at 7 ms against the configured 10: every stamp 2.9 ms early).
    // A frame or two into the stream: the line starts again from the frames it knows.
    mapper_ = timesync::ClockMapper(mapper_.config());
  }
  exposures_reported_ = true;
  exposure_ns_ = m.exposure_ns;
  if (m.exposure_seq == m.seq) {  // the frame's own exposure (its chunk data): observed at once
    mapper_.observe(device, m.first_rx_ns - m.exposure_ns);
    pending_.clear();
    return;
  }
  // The frame whose exposure just came is observed with it (those before it never got theirs).
  const auto it = std::find_if(pending_.begin(), pending_.end(), [&](const Pending& p) { return p.seq == m.exposure_seq; });
  if (it != pending_.end()) {
    mapper_.observe(it->device, it->first_rx - m.exposure_ns);
    pending_.erase(pending_.begin(), it + 1);
  }
  pending_.push_back({m.seq, device, m.first_rx_ns});
  while (pending_.size() > kMaxPending) pending_.pop_front();
}

Nanos FrameClock::trigger_reference(const camera::FrameMeta& m) const noexcept {
  const Nanos by_arrival = m.first_rx_ns - (m.exposure_ns > 0 ? m.exposure_ns : exposure_ns_);  // the latest exposure known
  if (m.domain != camera::TimeDomain::kDeviceTicks || m.device_ns == 0) return by_arrival;
  const auto r = mapper_.map(m.device_ns);
  if (!r.valid || (r.state != timesync::SyncState::kLocked && r.state != timesync::SyncState::kHoldover)) return by_arrival;
  // Only for a frame the network held (its arrival later than its locked line by more than a
  // transport's jitter): otherwise the arrival, as before.
  const Nanos by_device = r.vehicle_ns + kMappedExposureSlackNs;
  return by_arrival - by_device > kHeldBeyondNs && by_arrival - by_device < kArrivalWindowNs ? by_device : by_arrival;
}

FrameStamp FrameClock::stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept {
  if (host_step_ns_ != 0) {  // the first frame dequeued after the step: its arrival is the host time after it
    mapper_.host_step(host_step_ns_, m.first_rx_ns);
    announced_step_ns_ = host_step_ns_;
    announced_at_ns_ = m.first_rx_ns;
    host_step_ns_ = 0;
  }
  if (m.domain != camera::TimeDomain::kMonotonic) {
    const bool ptp_then = domain_ == camera::TimeDomain::kVehicle, ptp_now = m.domain == camera::TimeDomain::kVehicle;
    if (have_domain_ && ptp_then != ptp_now) ptp_changed_at_ns_ = m.first_rx_ns;
    have_domain_ = true;
    domain_ = m.domain;
    announce_ptp_step(m.first_rx_ns);  // a step the ticks showed before the status poll said so
  }
  FrameStamp s = device_stamp(m, tick_ns);
  if (s.doubtful) late_shift_ns_ = mapper_.deviation().shift_ns;
  // Every source through the one filter: trigger ticks bypassed it, so after a host step back a
  // triggered camera's topic went back with its ticks and forward again with its mapped exposures.
  s.vehicle_ns = monotonic_.apply(s.vehicle_ns);
  s.slewed = monotonic_.status().correction_ns > kSlewFlagNs;
  return s;
}

FrameStamp FrameClock::device_stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept {
  // Exposure start can lie neither after the first packet arrived nor long before its exposure.
  const auto plausible = [&](Nanos t) { return t <= m.first_rx_ns && t >= m.first_rx_ns - exposure_ns_ - kArrivalWindowNs; };
  const auto reject = [&](Nanos t, bool step) {
    ++rejected_.count;
    if (step) ++rejected_.steps;
    rejected_.last_ns = m.first_rx_ns;
    rejected_.last_error_ns = t - (m.first_rx_ns - exposure_ns_);
  };
  switch (m.domain) {
    case camera::TimeDomain::kMonotonic: {
      // The offset of the two clocks sampled together at this frame's dequeue: a clock step
      // (NTP/PTP slew or jump) shows in the next frame, not never.
      const Nanos t = m.device_ns + (m.complete_ns - m.complete_mono_ns);
      return {t, StampSource::kMonotonic, t};
    }
    case camera::TimeDomain::kVehicle: {
      // PTP time: kept only where it agrees with the arrival; the mapper follows the raw ticks all
      // along, so a PTP stamp found wrong (or a PTP drop) falls back to a fresh line.
      const Nanos raw = m.device_ticks_ns != 0 ? m.device_ticks_ns : m.device_ns;
      // A small step of the raw ticks is the servo correcting the clock (a cold start's
      // Uncalibrated -> Slave, ~ms): the PTP stamp is taken. A step beyond the mapper's jump
      // threshold while PTP says locked is a clock that lost its master before the status poll
      // (up to a second) says so: refused until the mapper confirms it, if the ticks went forward
      // (or far back). Ticks later than their line by up to late_shift_max_ns are a held network as
      // much as that clock stepped back: the PTP stamp (the exposure, for a held frame) is kept,
      // flagged `doubtful` while the mapper waits (doubt()).
      observe(m, raw);
      announce_ptp_step(m.first_rx_ns);
      const auto deviation = mapper_.deviation();
      const Doubt ticks = doubt(deviation, m.first_rx_ns);
      const bool big = deviation.shift_ns > kPtpStepNs || deviation.shift_ns < -kPtpStepNs;
      const bool ptp_stepped = ticks.refuse && big;
      if (plausible(m.device_ns) && !ptp_stepped)
        return {m.device_ns, StampSource::kVehicle, m.device_ns, false, false, ticks.doubtful && big};
      reject(m.device_ns, ptp_stepped);
      const auto r = mapper_.map(raw);
      if (r.valid && r.state == timesync::SyncState::kLocked && plausible(r.vehicle_ns) && !ticks.refuse) {
        FrameStamp s{r.vehicle_ns, StampSource::kDeviceMapped, r.vehicle_ns, false, true, ticks.doubtful};
        floor_ = mapper_.floor_support(kFloorBuckets, kFloorToleranceNs);
        s.floor_unseen = !floor_seen(floor_);
        return s;
      }
      return {m.first_rx_ns - exposure_ns_, StampSource::kHostFallback, 0, false, true};
    }
    case camera::TimeDomain::kDeviceTicks:
      break;
  }
  observe(m, m.device_ns);
  announce_ptp_step(m.first_rx_ns);
  auto r = mapper_.map(m.device_ns);
  // A device clock step the mapper has not confirmed yet: far outside the window (a PTP cold start,
  // decades), or inside it, where only the arrivals disagreeing with the line show it.
  // (A step forward by decades also puts the mapping out of holdover: invalid, still a step.)
  const auto deviation = mapper_.deviation();
  const Doubt line = doubt(deviation, m.first_rx_ns);
  const bool stepped = line.refuse;
  bool replaced = false;
  if (stepped || (r.valid && !plausible(r.vehicle_ns))) {
    // The old line puts the exposure start the step off what the arrival says.
    reject(r.valid ? r.vehicle_ns : m.first_rx_ns - exposure_ns_ - deviation.shift_ns, stepped);
    r.valid = false;
    replaced = true;
  }
  // The device's exposure start (for the trigger's phase figure) only from a locked mapping: before,
  // the line is the first frames' arrivals, whose host delay (40 ms under load) it would carry. A
  // locked line in holdover (no frame accepted for a second: a held network's late arrivals are not
  // taken) is as good, by the drift times the gap (~1 us/s): its trigger tick was the call, 0.4 ms
  // before the exposure at p50 and 1.5 ms under load (whole-rig campaign seed 25, a held stereo frame).
  const bool mapped = r.valid && (r.state == timesync::SyncState::kLocked || r.state == timesync::SyncState::kHoldover);
  const Nanos device = mapped ? r.vehicle_ns : 0;
  if (mapped) floor_ = mapper_.floor_support(kFloorBuckets, kFloorToleranceNs);
  const bool floor_unseen = mapped && !floor_seen(floor_);
  if (tick_ns > 0 && tick_ns <= m.first_rx_ns) {
    // The tick is when the exposure was asked for; a locked device clock mapping says when it happened.
    // A mapped exposure after the frame arrived, or long before its trigger, is the mapping's
    // error, not the camera's: the tick then.
    const bool near_tick = mapped && r.vehicle_ns >= tick_ns - kMappedExposureSlackNs;
    // (A line that a clock stepped back put more than the slack early gives the tick: right.)
    if (near_tick) return {r.vehicle_ns, StampSource::kTriggerExposure, device, false, false, line.doubtful, floor_unseen};
    return {tick_ns, StampSource::kTriggerTick, device, false, replaced};
  }
  if (r.valid) return {r.vehicle_ns, StampSource::kDeviceMapped, device, false, false, line.doubtful, floor_unseen};
  return {m.first_rx_ns - exposure_ns_, StampSource::kHostFallback, 0, false, replaced};
}

}  // namespace sensor_rig::drivers
