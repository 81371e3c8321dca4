#include "sensor_rig/timesync/packet_stamper.hpp"

namespace sensor_rig::timesync {

const char* to_string(AbsoluteSource s) noexcept {
  switch (s) {
    case AbsoluteSource::kNone: return "none";
    case AbsoluteSource::kSensorRaw: return "sensor_raw";
    case AbsoluteSource::kSensorSynced: return "sensor_synced";
    case AbsoluteSource::kSensorMapped: return "sensor_mapped";
    case AbsoluteSource::kHostFallback: return "host_fallback";
  }
  return "unknown";
}

PacketStamper::PacketStamper(const StamperConfig& cfg) : cfg_(cfg), hour_(cfg) {}

Nanos PacketStamper::stamp(const DevicePacket& p) noexcept {
  const Nanos host_stamp = p.rx_ns - cfg_.packet_duration_ns;
  if (cfg_.source == TimeSource::kHost) return host_stamp;
  switch (p.kind) {
    case DeviceTimeKind::kMicrosSinceHour: {
      PacketTime pt;
      pt.sensor_us = static_cast<std::uint32_t>(p.value);
      pt.rx_ns = p.rx_ns;
      pt.gprmc_utc_ns = p.gprmc_utc_ns;
      pt.pps = p.pps;
      return hour_.stamp(pt).vehicle_ns;
    }
    case DeviceTimeKind::kAbsoluteNs:
      return stamp_absolute(p.value, host_stamp);
    case DeviceTimeKind::kNone:
      break;
  }
  return host_stamp;  // no usable device time: the decoder counts the packet if it is bad
}

void PacketStamper::host_step(Nanos step_ns, Nanos host_now_ns) noexcept {
  hour_.host_step(step_ns, host_now_ns);
  absolute_.host_step(step_ns, host_now_ns);
}

Nanos PacketStamper::doubtful_shift_ns() const noexcept {
  if (cfg_.source == TimeSource::kHost) return 0;  // arrival stamps: a held network is their truth
  // Only stamps that rest on the mapping (or on a clock it says is synced) are in doubt; a GPS-timed
  // sensor's or a `correction: never` sensor's time is taken as it is whatever the arrivals do.
  const bool absolute = absolute_source_ == AbsoluteSource::kSensorSynced || absolute_source_ == AbsoluteSource::kSensorMapped;
  if (const auto d = absolute_.deviation(); absolute && d.awaiting_late) return d.shift_ns;
  if (const auto d = hour_.mapper().deviation(); hour_.last_source() == StampSource::kSensorMapped && d.awaiting_late)
    return d.shift_ns;
  return 0;
}

Nanos PacketStamper::stamp_absolute(std::int64_t device_ns, Nanos host_stamp) noexcept {
  // A PTP- or GPS-synced device's time is vehicle time; a free-running one is mapped.
  absolute_.observe(device_ns, host_stamp);
  if (cfg_.correction == Correction::kNever) {
    absolute_source_ = AbsoluteSource::kSensorRaw;
    return device_ns;
  }
  const auto mapped = absolute_.map(device_ns);
  if (!mapped.valid) {
    absolute_source_ = AbsoluteSource::kHostFallback;
    return host_stamp;
  }
  // While the line converges its offset is the device's plus the least delay seen yet (delays only
  // add): on a loaded host that is milliseconds, and a PTP-synced sensor went out mapped, its stamps
  // 1.1 ms late (a fresh-clone suite run). Until the line has locked, a device up to
  // kConvergingDelayNs behind the receive times is taken as synced; the locked line decides then.
  const Nanos offset = mapped.vehicle_ns - device_ns;
  const Nanos upper = mapped.state == SyncState::kConverging ? kConvergingDelayNs : kSyncedWithinNs;
  if (cfg_.correction == Correction::kAuto && offset > -kSyncedWithinNs && offset < upper) {
    absolute_source_ = AbsoluteSource::kSensorSynced;
    return device_ns;
  }
  absolute_source_ = AbsoluteSource::kSensorMapped;
  return mapped.vehicle_ns;
}

}  // namespace sensor_rig::timesync
