#pragma once
// Ouster lidar packet -> scan decoder (every profile of profile.hpp). Pure: no I/O, no clock reads.
//
//   Decoder dec({.metadata = parse_metadata(text, name)});   // throws MetadataError / invalid_argument
//   if (auto scan = dec.push(packet, stamp)) publish(std::move(*scan));
//
// `stamp` is the vehicle time of the packet's first valid column (the caller maps
// packet_time() — that column's sensor timestamp — to vehicle time). Points are in Ouster's sensor
// frame, which is REP 103 (x forward = away from the connector, y left, z up), metres, column by
// column in packet order. point.t = (column timestamp - the packet's first valid column
// timestamp) + (stamp - Scan::stamp). A scan is one frame (frame id); it is emitted with the
// packet holding the last column of the column window, or when the frame id changes.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar::ouster {

// Dual-return profiles: strongest = the stronger echo, last = the farther of the two echoes the
// sensor reports, dual = both. Single-return profiles give their one echo whatever is selected.
enum class ReturnSelection : std::uint8_t { kStrongest, kLast, kDual };
// point.intensity: signal photons (profiles without signal fall back to reflectivity), or the
// calibrated reflectivity.
enum class IntensitySource : std::uint8_t { kSignal, kReflectivity };

struct DecoderConfig {
  SensorMetadata metadata;
  ReturnSelection returns = ReturnSelection::kStrongest;
  IntensitySource intensity = IntensitySource::kSignal;
  double min_range_m = 0.0;  // zero range (no return) is always dropped
  double max_range_m = std::numeric_limits<double>::infinity();
  // The scan the decoder joins mid-frame is partial: emitted only when this is set.
  bool emit_partial_scans = false;
  // A packet time more than this after the previous one (or a step back > 1 ms) ends the scan as partial.
  Nanos max_packet_gap_ns = 1'000'000'000;
};

inline constexpr std::size_t kStatusCount = 7;  // PacketStatus values

struct DecoderStats {
  std::uint64_t packets = 0;
  std::uint64_t packets_used = 0;
  std::array<std::uint64_t, kStatusCount> by_status{};  // indexed by PacketStatus
  std::uint64_t scans = 0;
  std::uint64_t partial_scans_discarded = 0;
  std::uint64_t time_jumps = 0;
  std::uint64_t invalid_columns = 0;         // status bit 0 clear: skipped
  std::uint64_t bad_measurement_ids = 0;     // measurement id >= columns_per_frame: skipped
  std::uint64_t init_id_mismatches = 0;      // packets whose init_id differs from the metadata's (decoded)
  [[nodiscard]] std::uint64_t dropped() const noexcept { return packets - packets_used; }
};

class Decoder {
 public:
  explicit Decoder(DecoderConfig config);
  ~Decoder();
  Decoder(Decoder&&) noexcept;
  Decoder& operator=(Decoder&&) noexcept;
  Decoder(const Decoder&) = delete;
  Decoder& operator=(const Decoder&) = delete;

  // Never throws; a rejected packet is counted (stats(), the scan's `dropped`).
  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept;
  std::optional<Scan> flush() noexcept;
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept;

  [[nodiscard]] PacketStatus last_status() const noexcept;
  [[nodiscard]] const DecoderStats& stats() const noexcept;
  [[nodiscard]] const DecoderConfig& config() const noexcept;
  [[nodiscard]] const PacketLayout& layout() const noexcept;
  // Ring (0 = lowest elevation) of beam (pixel row) `beam`.
  [[nodiscard]] std::uint16_t ring_of_beam(std::size_t beam) const noexcept;
  // The sensor timestamp of the first valid column, if the packet has the right size and one.
  [[nodiscard]] std::optional<std::uint64_t> first_column_time(std::span<const std::byte> bytes) const noexcept;
  // First column to the last column of one packet's time: columns_per_packet x column period.
  [[nodiscard]] Nanos packet_span_ns() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::lidar::ouster
