#pragma once
// Stamper: vehicle time of a Velodyne data packet's first firing, called once per packet by the
// LIDAR driver. Combines TopOfHourClock (µs since hour -> absolute sensor time) with a ClockMapper
// (sensor clock -> vehicle time when the sensor is not GPS-synchronised), or uses the kernel
// receive time. Pure: every time is an argument; no clock reads, no I/O, never throws after
// construction.
#include <cstdint>
#include <optional>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/pps_state.hpp"
#include "sensor_rig/timesync/clock_mapper.hpp"
#include "sensor_rig/timesync/top_of_hour.hpp"

namespace sensor_rig::timesync {

enum class TimeSource : std::uint8_t {
  kSensor = 0,  // the packet's own timestamp (top of hour + µs), mapped when needed
  kHost,        // kernel receive time minus the packet's duration
};
const char* to_string(TimeSource s) noexcept;

// When to pass sensor time through the ClockMapper.
enum class Correction : std::uint8_t {
  kAuto = 0,  // unless the sensor is GPS-synchronised (PPS locked and a GPRMC sentence present)
  kAlways,
  kNever,
};
const char* to_string(Correction c) noexcept;

using sensor_rig::PpsState;  // common/pps_state.hpp: one enum for the decoder and timesync

// Where a stamp came from (diagnostics).
enum class StampSource : std::uint8_t {
  kGps = 0,       // sensor time, sensor GPS-synchronised: taken as vehicle time
  kSensorMapped,  // sensor time through the ClockMapper
  kSensorRaw,     // sensor time as is (Correction::kNever, not GPS-synchronised)
  kHost,          // TimeSource::kHost
  kHostFallback,  // sensor mode, but no usable sensor time or mapping yet: host time instead
};
const char* to_string(StampSource s) noexcept;

struct StamperConfig {
  TimeSource source = TimeSource::kSensor;
  TopOfHourConfig hour;                 // hour from GPRMC (host fallback) or host
  Correction correction = Correction::kAuto;
  Nanos packet_duration_ns = 0;         // first firing -> packet sent (VLP-16: 12 x 55.296 µs)
  Nanos host_latency_ns = 0;            // known minimum send -> kernel receive delay
  ClockMapperConfig mapper;             // its fixed_delay_ns is replaced by host_latency_ns

  void validate() const;  // throws std::invalid_argument
};

struct PacketTime {
  std::uint32_t sensor_us = 0;          // the packet's µs since the top of the hour
  Nanos rx_ns = 0;                      // kernel receive time (vehicle clock)
  std::optional<Nanos> gprmc_utc_ns;    // latest valid $GPRMC time, if any
  PpsState pps = PpsState::kUnknown;
};

struct Stamp {
  Nanos vehicle_ns = 0;  // first firing of the packet, vehicle time (always set)
  StampSource source = StampSource::kHost;
  SyncState sync = SyncState::kUnsynced;  // mapper state (kLocked for kGps)
  bool ok = true;        // false: the sensor timestamp was unusable (counted)
};

struct StamperStatus {
  TimeSource mode = TimeSource::kSensor;
  StampSource last_source = StampSource::kHost;
  HourSource hour_source = HourSource::kNone;  // what placed the hour of the last packet
  SyncState sync = SyncState::kUnsynced;       // kLocked when GPS-synchronised
  PpsState pps = PpsState::kUnknown;
  bool gprmc = false;
  std::uint64_t packets = 0;
  std::uint64_t bad_timestamps = 0;  // sensor time unusable (µs >= 1 h, no GPRMC when required)
  std::uint64_t host_fallbacks = 0;
  std::uint64_t backwards = 0;       // stamp earlier than the previous packet's
  TopOfHourStats hour;
  ClockMapperStatus mapper;          // sensor clock vs vehicle time (observed in every mode)
};

class Stamper {
 public:
  explicit Stamper(StamperConfig cfg = {});  // throws std::invalid_argument

  Stamp stamp(const PacketTime& p) noexcept;

  [[nodiscard]] StamperStatus status() const;
  [[nodiscard]] StamperStatus status(Nanos host_now_ns) const;  // with mapper holdover by host time
  [[nodiscard]] const ClockMapper& mapper() const noexcept { return mapper_; }
  [[nodiscard]] StampSource last_source() const noexcept { return last_source_; }
  // CLOCK_REALTIME stepped (ClockMapper::host_step).
  void host_step(Nanos step_ns, Nanos host_now_ns) noexcept { mapper_.host_step(step_ns, host_now_ns); }
  [[nodiscard]] const StamperConfig& config() const noexcept { return cfg_; }

 private:
  static ClockMapperConfig mapper_config(const StamperConfig& c);

  StamperConfig cfg_;
  TopOfHourClock hour_;
  ClockMapper mapper_;
  StampSource last_source_ = StampSource::kHost;
  HourSource last_hour_source_ = HourSource::kNone;
  PpsState pps_ = PpsState::kUnknown;
  bool gprmc_ = false;
  bool gps_ = false;
  std::uint64_t packets_ = 0;
  std::uint64_t bad_ = 0;
  std::uint64_t fallbacks_ = 0;
  std::uint64_t backwards_ = 0;
  Nanos last_stamp_ns_ = 0;
};

}  // namespace sensor_rig::timesync
