#include "sensor_rig/timesync/stamper.hpp"

#include <limits>
#include <stdexcept>

namespace sensor_rig::timesync {

const char* to_string(TimeSource s) noexcept {
  switch (s) {
    case TimeSource::kSensor: return "sensor";
    case TimeSource::kHost: return "host";
  }
  return "unknown";
}

const char* to_string(Correction c) noexcept {
  switch (c) {
    case Correction::kAuto: return "auto";
    case Correction::kAlways: return "always";
    case Correction::kNever: return "never";
  }
  return "unknown";
}

const char* to_string(StampSource s) noexcept {
  switch (s) {
    case StampSource::kGps: return "gps";
    case StampSource::kSensorMapped: return "sensor_mapped";
    case StampSource::kSensorRaw: return "sensor_raw";
    case StampSource::kHost: return "host";
    case StampSource::kHostFallback: return "host_fallback";
  }
  return "unknown";
}

void StamperConfig::validate() const {
  if (packet_duration_ns < 0 || packet_duration_ns > 1'000'000'000)
    throw std::invalid_argument("StamperConfig.packet_duration_ns: must be in 0..1 s");
  if (host_latency_ns < 0 || host_latency_ns > 1'000'000'000)
    throw std::invalid_argument("StamperConfig.host_latency_ns: must be in 0..1 s");
  hour.validate();
  ClockMapperConfig m = mapper;
  m.fixed_delay_ns = host_latency_ns;
  m.validate();
}

ClockMapperConfig Stamper::mapper_config(const StamperConfig& c) {
  ClockMapperConfig m = c.mapper;
  m.fixed_delay_ns = c.host_latency_ns;
  return m;
}

Stamper::Stamper(StamperConfig cfg)
    : cfg_((cfg.validate(), cfg)), hour_(cfg_.hour), mapper_(mapper_config(cfg_)) {}

Stamp Stamper::stamp(const PacketTime& p) noexcept {
  ++packets_;
  pps_ = p.pps;
  gprmc_ = p.gprmc_utc_ns.has_value();
  Stamp s;
  // Both subtrahends are <= 1 s (validated); keep garbage receive times from overflowing.
  constexpr Nanos kFloor = std::numeric_limits<Nanos>::min() + 2'000'000'001;
  const Nanos host_first =
      p.rx_ns < kFloor ? p.rx_ns : p.rx_ns - cfg_.packet_duration_ns - cfg_.host_latency_ns;

  if (cfg_.source == TimeSource::kSensor) {
    const HourResult h = hour_.resolve(p.sensor_us, p.rx_ns, p.gprmc_utc_ns);
    last_hour_source_ = h.source;
    if (h.status != HourStatus::kOk) {
      ++bad_;
      s.ok = false;
    } else {
      // The packet leaves the sensor after its last firing: that is what the receive time sees.
      mapper_.observe(h.sensor_ns + cfg_.packet_duration_ns, p.rx_ns);
      gps_ = p.pps == PpsState::kLocked && gprmc_;  // the sensor disciplines its clock to GPS
      const bool correct = cfg_.correction == Correction::kAlways ||
                           (cfg_.correction == Correction::kAuto && !gps_);
      if (!correct) {
        s.vehicle_ns = h.sensor_ns;
        s.source = gps_ ? StampSource::kGps : StampSource::kSensorRaw;
        s.sync = gps_ ? SyncState::kLocked : mapper_.state();
      } else if (const MapResult m = mapper_.map(h.sensor_ns); m.valid) {
        s.vehicle_ns = m.vehicle_ns;
        s.source = StampSource::kSensorMapped;
        s.sync = m.state;
      } else {
        s.source = StampSource::kHostFallback;  // cannot happen after observe(); stay defined
      }
    }
    if (!s.ok || s.source == StampSource::kHostFallback) {
      s.vehicle_ns = host_first;
      s.source = StampSource::kHostFallback;
      s.sync = mapper_.state();
      ++fallbacks_;
    }
  } else {
    s.vehicle_ns = host_first;
    s.source = StampSource::kHost;
    s.sync = SyncState::kUnsynced;
  }
  if (packets_ > 1 && s.vehicle_ns < last_stamp_ns_) ++backwards_;
  last_stamp_ns_ = s.vehicle_ns;
  last_source_ = s.source;
  return s;
}

StamperStatus Stamper::status() const {
  StamperStatus st;
  st.mode = cfg_.source;
  st.last_source = last_source_;
  st.hour_source = last_hour_source_;
  st.pps = pps_;
  st.gprmc = gprmc_;
  st.packets = packets_;
  st.bad_timestamps = bad_;
  st.host_fallbacks = fallbacks_;
  st.backwards = backwards_;
  st.hour = hour_.stats();
  st.mapper = mapper_.status();
  st.sync = last_source_ == StampSource::kGps ? SyncState::kLocked : st.mapper.state;
  return st;
}

StamperStatus Stamper::status(Nanos host_now_ns) const {
  StamperStatus st = status();
  st.mapper = mapper_.status(host_now_ns);
  if (last_source_ != StampSource::kGps) st.sync = st.mapper.state;
  return st;
}

}  // namespace sensor_rig::timesync
