#include "sensor_rig/drivers/camera/frame_clock.hpp"

namespace sensor_rig::drivers {
namespace {

// How far before its trigger tick a mapped exposure start may fall (the mapping's error).
constexpr Nanos kMappedExposureSlackNs = 5'000'000;

timesync::ClockMapperConfig mapper_config(Nanos exposure_ns) {
  timesync::ClockMapperConfig c;
  c.fixed_delay_ns = exposure_ns;
  // A frame every 33-100 ms: buckets of 200 ms keep a few samples each for the minimum.
  c.bucket_ns = 200'000'000;
  c.lock_buckets = 5;
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
}

FrameStamp FrameClock::stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept {
  FrameStamp s = device_stamp(m, tick_ns);
  if (s.source != StampSource::kTriggerTick) s.vehicle_ns = monotonic_.apply(s.vehicle_ns);
  return s;
}

FrameStamp FrameClock::device_stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept {
  switch (m.domain) {
    case camera::TimeDomain::kMonotonic: {
      // The offset of the two clocks sampled together at this frame's dequeue: a clock step
      // (NTP/PTP slew or jump) shows in the next frame, not never.
      const Nanos t = m.device_ns + (m.complete_ns - m.complete_mono_ns);
      return {t, StampSource::kMonotonic, t};
    }
    case camera::TimeDomain::kVehicle:
      return {m.device_ns, StampSource::kVehicle, m.device_ns};
    case camera::TimeDomain::kDeviceTicks:
      break;
  }
  mapper_.observe(m.device_ns, m.first_rx_ns);
  const auto r = mapper_.map(m.device_ns);
  const Nanos device = r.valid ? r.vehicle_ns : 0;
  if (tick_ns > 0 && tick_ns <= m.first_rx_ns) {
    // The tick is when the exposure was asked for; a locked device clock mapping says when it happened.
    // A mapped exposure after the frame arrived, or long before its trigger, is the mapping's
    // error, not the camera's: the tick then.
    const bool plausible = r.valid && r.state == timesync::SyncState::kLocked && r.vehicle_ns <= m.first_rx_ns &&
                           r.vehicle_ns >= tick_ns - kMappedExposureSlackNs;
    if (plausible) return {r.vehicle_ns, StampSource::kTriggerExposure, device};
    return {tick_ns, StampSource::kTriggerTick, device};
  }
  if (r.valid) return {r.vehicle_ns, StampSource::kDeviceMapped, device};
  return {m.first_rx_ns - exposure_ns_, StampSource::kHostFallback, 0};
}

}  // namespace sensor_rig::drivers
