#pragma once
// TopOfHourClock: absolute time of a Velodyne-style timestamp (µs since the top of the hour,
// wrapping every hour). The hour is the one that puts the sensor time nearest a reference:
// the GPRMC time (aged by host time since it was first seen), or the host receive time. Once
// anchored, continuity (last absolute time advanced by host time) carries the hour across the
// hourly wrap and across packets received either side of a boundary. Pure: no clock reads.
#include <cstdint>
#include <optional>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

inline constexpr Nanos kHourNs = 3'600'000'000'000;
inline constexpr std::uint32_t kMicrosPerHour = 3'600'000'000u;

enum class HourSource : std::uint8_t {
  kGprmc = 0,  // hour from the GPS sentence the sensor forwards (falls back to host without one)
  kHost,       // hour from the host receive time
  kNone,       // no hour could be chosen (bad timestamp, or GPRMC required and absent)
};
const char* to_string(HourSource s) noexcept;

struct TopOfHourConfig {
  HourSource hour_source = HourSource::kGprmc;
  bool host_fallback = true;                   // kGprmc without a sentence: use the host hour
  Nanos continuity_max_gap_ns = 10'000'000'000;  // longer host gaps re-anchor from the reference

  void validate() const;  // throws std::invalid_argument
};

enum class HourStatus : std::uint8_t {
  kOk = 0,
  kBadTimestamp,  // µs value >= one hour
  kNoReference,   // kGprmc required (no host fallback) and no sentence seen yet
};
const char* to_string(HourStatus s) noexcept;

struct HourResult {
  Nanos sensor_ns = 0;                   // absolute sensor time (sensor clock, ns since epoch)
  HourStatus status = HourStatus::kNoReference;
  HourSource source = HourSource::kNone;  // the reference that chose the hour
  bool hour_changed = false;             // a different hour than the previous packet's
};

struct TopOfHourStats {
  std::uint64_t packets = 0;
  std::uint64_t bad_timestamps = 0;
  std::uint64_t no_reference = 0;
  std::uint64_t wraps = 0;             // forward hour changes (the hourly wrap)
  std::uint64_t backward_changes = 0;  // hour went back (reordering across a boundary, or a step)
  std::uint64_t corrections = 0;       // GPRMC disagreed with continuity by whole hours
  HourSource last_source = HourSource::kNone;
  Nanos hour_start_ns = 0;             // hour of the last good packet
};

// Absolute time nearest `reference_ns` whose µs-within-hour is `sensor_us` (< kMicrosPerHour).
Nanos nearest_hour_time(std::uint32_t sensor_us, Nanos reference_ns) noexcept;

class TopOfHourClock {
 public:
  explicit TopOfHourClock(TopOfHourConfig cfg = {});  // throws std::invalid_argument

  // gprmc_utc_ns: the UTC time carried by the latest $GPRMC sentence (full time, not only the
  // hour: it places packets sent either side of an hour boundary correctly).
  HourResult resolve(std::uint32_t sensor_us, Nanos host_rx_ns,
                     std::optional<Nanos> gprmc_utc_ns) noexcept;

  [[nodiscard]] const TopOfHourStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const TopOfHourConfig& config() const noexcept { return cfg_; }

 private:
  TopOfHourConfig cfg_;
  TopOfHourStats stats_;
  bool anchored_ = false;
  Nanos last_abs_ns_ = 0;
  Nanos last_rx_ns_ = 0;
  Nanos highest_hour_ns_ = 0;
  std::optional<Nanos> gprmc_;  // the latest sentence time and the host time it was first seen
  Nanos gprmc_seen_rx_ns_ = 0;
};

}  // namespace sensor_rig::timesync
