#include "sensor_rig/timesync/top_of_hour.hpp"

#include <algorithm>
#include <stdexcept>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::timesync {

namespace {
constexpr Nanos kRefLimit = Nanos{1} << 61;  // a + (b - c) of clamped values cannot overflow

Nanos clamp_ref(Nanos v) noexcept { return std::clamp(v, -kRefLimit, kRefLimit); }
// a + (b - c) with every operand clamped: host times from garbage input must not overflow.
Nanos advance(Nanos a, Nanos b, Nanos c) noexcept {
  return clamp_ref(clamp_ref(a) + (clamp_ref(b) - clamp_ref(c)));
}
}  // namespace

const char* to_string(HourSource s) noexcept {
  switch (s) {
    case HourSource::kGprmc: return "gprmc";
    case HourSource::kHost: return "host";
    case HourSource::kNone: return "none";
  }
  return "unknown";
}

const char* to_string(HourStatus s) noexcept {
  switch (s) {
    case HourStatus::kOk: return "ok";
    case HourStatus::kBadTimestamp: return "bad_timestamp";
    case HourStatus::kNoReference: return "no_reference";
  }
  return "unknown";
}

void TopOfHourConfig::validate() const {
  if (hour_source == HourSource::kNone)
    throw std::invalid_argument("TopOfHourConfig.hour_source: must be gprmc or host");
  if (continuity_max_gap_ns <= 0 || continuity_max_gap_ns >= kHourNs / 4)
    throw std::invalid_argument("TopOfHourConfig.continuity_max_gap_ns: must be in (0, 15 min)");
}

Nanos nearest_hour_time(std::uint32_t sensor_us, Nanos reference_ns) noexcept {
  const Nanos t = static_cast<Nanos>(std::min(sensor_us, kMicrosPerHour - 1)) * 1000;
  const Nanos k = floor_div(clamp_ref(reference_ns) - t + kHourNs / 2, kHourNs);
  return k * kHourNs + t;
}

TopOfHourClock::TopOfHourClock(TopOfHourConfig cfg) : cfg_(cfg) { cfg_.validate(); }

HourResult TopOfHourClock::resolve(std::uint32_t sensor_us, Nanos host_rx_ns,
                                   std::optional<Nanos> gprmc_utc_ns) noexcept {
  ++stats_.packets;
  HourResult r;
  if (sensor_us >= kMicrosPerHour) {
    ++stats_.bad_timestamps;
    r.status = HourStatus::kBadTimestamp;
    return r;
  }
  // Age the sentence by host time since it was first seen: it may be a second or more old.
  if (!gprmc_utc_ns) {
    gprmc_.reset();
  } else if (!gprmc_ || *gprmc_ != *gprmc_utc_ns) {
    gprmc_ = gprmc_utc_ns;
    gprmc_seen_rx_ns_ = host_rx_ns;
  }
  const Nanos rx_gap = advance(host_rx_ns, 0, last_rx_ns_);
  const bool continuity = anchored_ && rx_gap <= cfg_.continuity_max_gap_ns &&
                          rx_gap >= -cfg_.continuity_max_gap_ns;
  const Nanos cont_abs =
      continuity ? nearest_hour_time(sensor_us, advance(last_abs_ns_, host_rx_ns, last_rx_ns_)) : 0;

  if (cfg_.hour_source == HourSource::kGprmc && gprmc_) {
    r.sensor_ns = nearest_hour_time(sensor_us, advance(*gprmc_, host_rx_ns, gprmc_seen_rx_ns_));
    r.source = HourSource::kGprmc;
    if (continuity && r.sensor_ns != cont_abs) ++stats_.corrections;
  } else if (cfg_.hour_source == HourSource::kGprmc && !cfg_.host_fallback) {
    ++stats_.no_reference;
    r.status = HourStatus::kNoReference;
    return r;
  } else if (continuity) {
    r.sensor_ns = cont_abs;
    r.source = stats_.last_source;  // the hour still comes from whatever anchored it
  } else {
    r.sensor_ns = nearest_hour_time(sensor_us, host_rx_ns);
    r.source = HourSource::kHost;
  }
  r.status = HourStatus::kOk;

  const Nanos hour = r.sensor_ns - static_cast<Nanos>(sensor_us) * 1000;
  if (anchored_ && hour != stats_.hour_start_ns) {
    r.hour_changed = true;
    if (hour > highest_hour_ns_) {
      ++stats_.wraps;
    } else if (hour < stats_.hour_start_ns) {
      ++stats_.backward_changes;  // back to the highest hour after a reordered packet: neither
    }
  }
  if (!anchored_ || hour > highest_hour_ns_) highest_hour_ns_ = hour;
  anchored_ = true;
  last_abs_ns_ = r.sensor_ns;
  last_rx_ns_ = host_rx_ns;
  stats_.hour_start_ns = hour;
  stats_.last_source = r.source;
  return r;
}

}  // namespace sensor_rig::timesync
