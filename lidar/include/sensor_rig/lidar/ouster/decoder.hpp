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
// A time jump is the stamps and the column times jumping together: stamps that jump while the
// column times go on are a mapping that moved (a host clock step), and the scan in progress keeps
// the line it began on (its later packets' stamp = their column time + its first packet's offset;
// DecoderStats::mapping_steps); the next scan takes the mapping as it is.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/lidar/decoder_pimpl.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/lidar/scan_assembler.hpp"

namespace sensor_rig::lidar::ouster {

// Dual-return profiles: strongest = the stronger echo, last = the farther of the two echoes the
// sensor reports, dual = both. Single-return profiles give their one echo whatever is selected.
using ReturnSelection = lidar::ReturnSelection;
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

inline constexpr std::size_t kStatusCount = kPacketStatusCount;

struct DecoderStats : ScanStats {
  std::uint64_t invalid_columns = 0;         // status bit 0 clear: skipped
  std::uint64_t bad_measurement_ids = 0;     // measurement id >= columns_per_frame: skipped
  std::uint64_t init_id_mismatches = 0;      // packets whose init_id differs from the metadata's (decoded)
  // mapping_steps (ScanStats): the scan in progress stays on the line it began on.
};

struct DecoderImpl;

// push / flush / recycle / stats as DecoderPimpl says; a rejected packet is counted.
class Decoder : public DecoderPimpl<DecoderImpl, DecoderConfig, DecoderStats> {
 public:
  explicit Decoder(DecoderConfig config);  // throws MetadataError / std::invalid_argument

  [[nodiscard]] const PacketLayout& layout() const noexcept;
  // Ring (0 = lowest elevation) of beam (pixel row) `beam`.
  [[nodiscard]] std::uint16_t ring_of_beam(std::size_t beam) const noexcept;
  // The sensor timestamp of the first valid column, if the packet has the right size and one.
  [[nodiscard]] std::optional<std::uint64_t> first_column_time(std::span<const std::byte> bytes) const noexcept;
  // First column to the last column of one packet's time: columns_per_packet x column period.
  [[nodiscard]] Nanos packet_span_ns() const noexcept;
};

}  // namespace sensor_rig::lidar::ouster

namespace sensor_rig::lidar {
extern template class DecoderPimpl<ouster::DecoderImpl, ouster::DecoderConfig, ouster::DecoderStats>;
}  // namespace sensor_rig::lidar
