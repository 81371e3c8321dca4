#pragma once
// One stamping policy for every LIDAR packet, used by the LIDAR node and by `rig lidar decode`:
// the packet's own time (µs since the hour with GPRMC/PPS, or absolute ns) or the kernel receive
// time, to the vehicle time of the packet's first firing. Pure: the caller passes every time in.
#include <cstdint>
#include <optional>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/pps_state.hpp"
#include "sensor_rig/timesync/clock_mapper.hpp"
#include "sensor_rig/timesync/stamper.hpp"

namespace sensor_rig::timesync {

// What a packet says about its own time (the device's clock, before any mapping).
enum class DeviceTimeKind : std::uint8_t {
  kNone = 0,         // no usable time in the packet: the kernel receive time is used
  kMicrosSinceHour,  // Velodyne: µs since the top of the hour; the hour from GPRMC or the host
  kAbsoluteNs,       // Ouster, Hesai: ns since the epoch in the device's clock (PTP, GPS or free-running)
};

struct DevicePacket {
  DeviceTimeKind kind = DeviceTimeKind::kNone;
  std::int64_t value = 0;              // µs since the hour, or ns since the epoch
  Nanos rx_ns = 0;                     // kernel receive time (vehicle clock)
  std::optional<Nanos> gprmc_utc_ns;   // latest valid $GPRMC time, if any (Velodyne)
  PpsState pps = PpsState::kUnknown;   // Velodyne position packets
};

// How the last absolute-time packet was stamped (diagnostics).
enum class AbsoluteSource : std::uint8_t { kNone = 0, kSensorRaw, kSensorSynced, kSensorMapped, kHostFallback };
const char* to_string(AbsoluteSource s) noexcept;

class PacketStamper {
 public:
  // cfg.packet_duration_ns: first firing -> packet sent (the decoder's packet span). Throws
  // std::invalid_argument for a bad config (Stamper's rules).
  explicit PacketStamper(const StamperConfig& cfg);

  // Vehicle time of the packet's first firing. Never throws; an unusable device time falls back
  // to the receive time (counted in the status).
  Nanos stamp(const DevicePacket& p) noexcept;

  [[nodiscard]] TimeSource source() const noexcept { return cfg_.source; }
  // Top-of-hour path (Velodyne): hour, GPRMC/PPS, mapper state.
  [[nodiscard]] StamperStatus hour_status(Nanos host_now_ns) const { return hour_.status(host_now_ns); }
  // Absolute-time path (Ouster, Hesai): how the last packet was stamped and the mapper state.
  [[nodiscard]] AbsoluteSource absolute_source() const noexcept { return absolute_source_; }
  [[nodiscard]] ClockMapperStatus absolute_status(Nanos host_now_ns) const { return absolute_.status(host_now_ns); }

  // CLOCK_REALTIME was stepped by step_ns (the caller's RealtimeStepDetector, at host_now_ns after
  // it): told to the mappers, so that the arrivals' shift is not held as a possible network delay.
  void host_step(Nanos step_ns, Nanos host_now_ns) noexcept;
  // The arrivals have been later than the sensor's clock says for longer than a step needs to be
  // confirmed, and not yet long enough to tell a held network from the sensor's clock stepping back
  // (ClockMapper::Deviation::awaiting_late): the stamps are doubtful until it is decided. 0: not
  // doubtful; else the shift (arrivals later by, ns).
  [[nodiscard]] Nanos doubtful_shift_ns() const noexcept;

  // |device - vehicle| below this: the device clock is synchronised (PTP/GPS) and taken as is.
  static constexpr Nanos kSyncedWithinNs = 1'000'000;
  // While the mapper converges: how far the receive times may lag a synced device's clock (the
  // least delay seen so far, which scheduling inflates) before the device is taken for free-running.
  static constexpr Nanos kConvergingDelayNs = 10'000'000;

 private:
  Nanos stamp_absolute(std::int64_t device_ns, Nanos host_stamp) noexcept;

  StamperConfig cfg_;
  Stamper hour_;
  ClockMapper absolute_;
  AbsoluteSource absolute_source_ = AbsoluteSource::kNone;
};

}  // namespace sensor_rig::timesync
