#pragma once
// What every synthetic LIDAR (Velodyne, Ouster, Hesai) gives the mock sender: an endless, time
// ordered stream of genuine packets rendered from a Scene. Pure: time is an input (the config's
// start time), no I/O, no clock reads.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar::mock {

// What a data packet truly is, for truth records (unit_tracker.hpp cuts scans from it as the
// vendor decoders do). Filled by the renderer from its own model, never parsed back from the bytes.
struct PacketTruth {
  static constexpr std::size_t kMaxGroups = 12;
  bool data = false;          // false: a position / IMU packet (no truth)
  std::uint64_t index = 0;    // the sensor's data packet number
  Nanos acq_ns = 0;           // first firing, vehicle time
  Nanos dev_ns = 0;           // the sensor clock's reading then, as the packet carries it (ns)
  double rotor_deg = 0.0;     // rotor at the first firing (SyntheticSensor::start_rotor_deg's convention)
  std::uint32_t frame = 0;    // Ouster: frame id
  std::uint8_t groups = 0;    // Velodyne / Hesai: firing groups (azimuth blocks; dual: block pairs)
  std::array<std::uint16_t, kMaxGroups> group_az{};  // each group's azimuth field (0.01°)
  std::array<Nanos, kMaxGroups> group_ns{};          // each group's first firing (vehicle time)
};

// One packet of a synthetic sensor's stream, in time order.
struct SyntheticPacket {
  Nanos time_ns = 0;                 // vehicle time the packet belongs to (see each sensor's header)
  std::span<const std::byte> bytes;  // valid until the next call to next()
  bool position = false;             // true: send to the position port (Velodyne 8308)
  PacketTruth truth;                 // data packets: what it is
};

// How the rig's decoders cut this sensor's scans (for the default cut angle 0), so that a truth
// record's units are the rig's scans: Velodyne ends a scan at the group whose azimuth crosses the
// cut; Hesai keeps a window [reset, emit] of groups that belong to both scans (nebula's per-point
// cut); Ouster starts a scan with each frame id.
struct UnitRule {
  enum class Kind : std::uint8_t { kAzimuthCut, kAzimuthWindow, kFrame } kind = Kind::kAzimuthCut;
  int reset_raw = 0;  // 0.01°: the window opens (Hesai); Velodyne: the cut
  int emit_raw = 0;   // 0.01°: the cut
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
  [[nodiscard]] virtual UnitRule unit_rule() const noexcept = 0;
};

}  // namespace sensor_rig::lidar::mock
