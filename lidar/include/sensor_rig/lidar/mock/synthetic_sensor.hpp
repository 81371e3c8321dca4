#pragma once
// What every synthetic LIDAR (Velodyne, Ouster, Hesai) gives the mock sender: an endless, time
// ordered stream of genuine packets rendered from a Scene. Pure: time is an input (the config's
// start time), no I/O, no clock reads.
#include <cstddef>
#include <span>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar::mock {

// One packet of a synthetic sensor's stream, in time order.
struct SyntheticPacket {
  Nanos time_ns = 0;                 // vehicle time the packet belongs to (see each sensor's header)
  std::span<const std::byte> bytes;  // valid until the next call to next()
  bool position = false;             // true: send to the position port (Velodyne 8308)
};

class SyntheticSensor {
 public:
  virtual ~SyntheticSensor() = default;
  virtual SyntheticPacket next() = 0;
  // Data packets per second (the model's real rate for the configured mode).
  [[nodiscard]] virtual double packets_per_second() const noexcept = 0;
  // The stream's first packet's time_ns minus the configured start time.
  [[nodiscard]] virtual Nanos first_packet_offset_ns() const noexcept = 0;
  // Moves the whole timeline (before the first next()): a mock sender aligns the sensor's clock
  // with its send schedule so that every packet leaves when its time_ns is reached.
  virtual void set_start_ns(Nanos start_ns) noexcept = 0;
  // One turn of the rotor (one scan) in ns.
  [[nodiscard]] virtual double rotation_period_ns() const noexcept = 0;
  // Where the rotor is at the timeline's start, in degrees past the scan boundary, growing with
  // time: Velodyne and Hesai the packets' azimuth (the decoders cut at 0 by default), Ouster the
  // measurement id x 360 / columns per frame (a frame starts at id 0).
  [[nodiscard]] virtual double start_rotor_deg() const noexcept = 0;
};

}  // namespace sensor_rig::lidar::mock
