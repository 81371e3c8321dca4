#include "sensor_rig/drivers/camera/frame_clock.hpp"

#include <algorithm>

namespace sensor_rig::drivers {
namespace {

// How far before its trigger tick a mapped exposure start may fall (the mapping's error).
constexpr Nanos kMappedExposureSlackNs = 5'000'000;
// A frame's first packet leaves at its exposure end; transport and a loaded host delay its arrival
// (a stalled fake by up to ~0.3 s in the campaigns), never by this much: an exposure start further
// back is a clock error (a 37 s TAI offset, a camera clock from 1970).
constexpr Nanos kArrivalWindowNs = 1'000'000'000;

constexpr std::size_t kMaxPending = 8;

// Consecutive samples later than the line by a consistent amount before the line is distrusted:
// one or two late frames are a host hiccup (the mapped stamp is right, the arrival is not); more,
// and a device clock stepped back is as likely (the mapped stamp would be the step off).
constexpr std::size_t kStepSamples = 3;

// A step of a PTP camera's raw ticks beyond this is no servo correction (the mapper's jump threshold).
constexpr Nanos kPtpStepNs = 10'000'000;

// The mapper's line disagrees with the recent arrivals: a device clock step it has not confirmed.
bool unconfirmed_step(const timesync::ClockMapper::Deviation& d) noexcept {
  return d.samples > 0 && (d.shift_ns < 0 || d.samples >= kStepSamples);
}

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
  // Late arrivals confirm like early ones here: the frame clock refuses the line's stamps while any
  // step is pending (unconfirmed_step below), so the 1 s above is already its window of doubt.
  c.late_confirm_ns = 0;
  return c;
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
}

void FrameClock::observe(const camera::FrameMeta& m, Nanos device) noexcept {
  if (m.exposure_seq == 0 || m.exposure_ns <= 0) {  // no per-frame exposure: the one known now
    mapper_.observe(device, m.first_rx_ns - exposure_ns_);
    return;
  }
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

FrameStamp FrameClock::stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept {
  FrameStamp s = device_stamp(m, tick_ns);
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
      // (up to a second) says so: refused until the mapper confirms it.
      observe(m, raw);
      const auto deviation = mapper_.deviation();
      const bool ticks_stepped = unconfirmed_step(deviation);
      const bool ptp_stepped = ticks_stepped && (deviation.shift_ns > kPtpStepNs || deviation.shift_ns < -kPtpStepNs);
      if (plausible(m.device_ns) && !ptp_stepped) return {m.device_ns, StampSource::kVehicle, m.device_ns};
      reject(m.device_ns, ptp_stepped);
      const auto r = mapper_.map(raw);
      if (r.valid && r.state == timesync::SyncState::kLocked && plausible(r.vehicle_ns) && !ticks_stepped)
        return {r.vehicle_ns, StampSource::kDeviceMapped, r.vehicle_ns, false, true};
      return {m.first_rx_ns - exposure_ns_, StampSource::kHostFallback, 0, false, true};
    }
    case camera::TimeDomain::kDeviceTicks:
      break;
  }
  observe(m, m.device_ns);
  auto r = mapper_.map(m.device_ns);
  // A device clock step the mapper has not confirmed yet: far outside the window (a PTP cold start,
  // decades), or inside it, where only the arrivals disagreeing with the line show it.
  // (A step forward by decades also puts the mapping out of holdover: invalid, still a step.)
  const auto deviation = mapper_.deviation();
  const bool stepped = unconfirmed_step(deviation);
  bool replaced = false;
  if (stepped || (r.valid && !plausible(r.vehicle_ns))) {
    // The old line puts the exposure start the step off what the arrival says.
    reject(r.valid ? r.vehicle_ns : m.first_rx_ns - exposure_ns_ - deviation.shift_ns, stepped);
    r.valid = false;
    replaced = true;
  }
  // The device's exposure start (for the trigger's phase figure) only from a locked mapping: before,
  // the line is the first frames' arrivals, whose host delay (40 ms under load) it would carry.
  const Nanos device = r.valid && r.state == timesync::SyncState::kLocked ? r.vehicle_ns : 0;
  if (tick_ns > 0 && tick_ns <= m.first_rx_ns) {
    // The tick is when the exposure was asked for; a locked device clock mapping says when it happened.
    // A mapped exposure after the frame arrived, or long before its trigger, is the mapping's
    // error, not the camera's: the tick then.
    const bool near_tick = r.valid && r.state == timesync::SyncState::kLocked && r.vehicle_ns >= tick_ns - kMappedExposureSlackNs;
    if (near_tick) return {r.vehicle_ns, StampSource::kTriggerExposure, device};
    return {tick_ns, StampSource::kTriggerTick, device, false, replaced};
  }
  if (r.valid) return {r.vehicle_ns, StampSource::kDeviceMapped, device};
  return {m.first_rx_ns - exposure_ns_, StampSource::kHostFallback, 0, false, replaced};
}

}  // namespace sensor_rig::drivers
