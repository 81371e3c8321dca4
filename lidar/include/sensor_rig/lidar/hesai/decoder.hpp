#pragma once
// Hesai packet -> scan decoder (Pandar40P, PandarXT32). Pure: no I/O, no clock reads.
//
//   Decoder dec(config);                         // throws DecoderConfigError
//   if (auto scan = dec.push(packet, stamp)) publish(std::move(*scan));
//
// `stamp` is the vehicle time of the packet's first firing (the caller maps the sensor's UTC time,
// read_packet_info() + first_firing_offset_ns(), to vehicle time). Points are written in the
// REP 103 frame (x forward, y left, z up; metres). Hesai's own frame is x right, y forward, z up
// with the azimuth clockwise from the front (nebula publishes that frame); here
//   A = block azimuth + channel azimuth offset,  x = d cos(el) cos(A),  y = -d cos(el) sin(A),  z = d sin(el).
// Points are in packet order: per azimuth group, per channel, the echoes in block order.
//
// Scan cut (nebula's rule): each point belongs to the scan its corrected azimuth A falls in, so a
// scan holds exactly the points with A in [cut, cut + 360°). Near the cut (the raw azimuth window
// [cut - max offset, cut - min offset]), points already past the cut go to the next scan; the scan
// is returned by the push() whose packet passes the window's end.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/lidar/decoder_pimpl.hpp"
#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/lidar/scan_assembler.hpp"

namespace sensor_rig::lidar::hesai {

// Which echoes to keep from dual-return packets (single-return packets keep their one echo).
// kStrongest: the echo with the higher reflectivity (the first block on a tie). kLast: the last
// echo (the farther one when the mode has no last echo). kDual: both, except that an echo
// identical to the other one, or closer than dual_distance_threshold_m to it, is kept once
// (the second block's), as nebula does.
using ReturnSelection = lidar::ReturnSelection;

struct DecoderConfig {
  Model model = Model::kPandar40P;
  std::optional<Calibration> calibration;    // nullopt: the manual's nominal angles
  std::optional<FiringTimes> firing_times;   // nullopt: the built-in Firetime table
  ReturnSelection returns = ReturnSelection::kStrongest;
  double min_range_m = 0.0;                  // points closer are dropped (zero distance always is)
  double max_range_m = std::numeric_limits<double>::infinity();
  double cut_angle_deg = 0.0;                // in [0, 360)
  bool emit_partial_scans = false;           // the first scan (mid-rotation) and scans ended by a time jump
  double dual_distance_threshold_m = 0.1;    // nebula's dual_return_distance_threshold
  // A packet time more than this after the previous one (or any step back > 1 ms) ends the
  // current scan as partial.
  Nanos max_packet_gap_ns = 1'000'000'000;
  // The sensor's own FOV setting (it sends only this clockwise arc); start == end: the whole turn.
  double fov_start_deg = 0.0;
  double fov_end_deg = 0.0;
  // Points reserved for the first scan buffers; 0: the model's typical scan (twice with kDual).
  // Later scans reserve the last scan's size. A small value costs only reallocations as a scan
  // grows (the fuzz harnesses: a decoder per input, no multi-MB reserve each).
  std::size_t first_scan_reserve_points = 0;
};

inline constexpr std::size_t kStatusCount = kPacketStatusCount;

struct DecoderStats : ScanStats {
  std::uint64_t corrupt_blocks = 0;       // azimuth groups off their packet's line: not decoded
  std::uint64_t sequence_mismatches = 0;  // UDP sequence numbers the azimuth/time step contradicts (not trusted)
  // mapping_steps (ScanStats): the scans begun stay on their line, the one after the next cut
  // takes the new.
};

struct DecoderImpl;

// push / flush / recycle / stats as DecoderPimpl says; flush() also discards the points already
// held for the next scan.
class Decoder : public DecoderPimpl<DecoderImpl, DecoderConfig, DecoderStats> {
 public:
  explicit Decoder(DecoderConfig config);  // throws DecoderConfigError

  // Offset of a packet's first firing from its tail time with this decoder's firing times (< 0).
  [[nodiscard]] Nanos first_firing_offset_ns(int returns) const noexcept;
  // Echoes per azimuth of the last valid packet (before any: 2 if dual was selected, else 1).
  [[nodiscard]] int last_returns() const noexcept;
  // Ring (0 = lowest elevation) of a channel (1-based, as in the calibration file).
  [[nodiscard]] std::uint16_t ring_of_channel(int channel) const noexcept;
};

}  // namespace sensor_rig::lidar::hesai

namespace sensor_rig::lidar {
extern template class DecoderPimpl<hesai::DecoderImpl, hesai::DecoderConfig, hesai::DecoderStats>;
}  // namespace sensor_rig::lidar
