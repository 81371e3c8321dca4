#pragma once
// Velodyne packet -> scan decoder (VLP-16, VLP-32C, HDL-32E). Pure: no I/O, no clock reads.
//
//   Decoder dec(config);                        // throws CalibrationError / std::invalid_argument
//   if (auto scan = dec.push(packet, stamp)) publish(std::move(*scan));
//   if (auto last = dec.flush()) ...            // trailing partial scan
//
// `stamp` is the vehicle time of the packet's first firing (the caller maps the sensor's
// µs-since-hour to vehicle time). Points are written straight into Scan::points in the REP 103
// frame (x forward, y left, z up; metres), in packet order; point.t is ns after Scan::stamp,
// which is the first firing of the scan's first block.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/lidar/decoder_pimpl.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/scan_assembler.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"

namespace sensor_rig::lidar::velodyne {

// Which echoes to keep. Dual-return packets carry pairs of blocks (last, strongest-or-second);
// single-return packets carry one echo, which is kept whatever is selected here.
using ReturnSelection = lidar::ReturnSelection;

// Azimuth of a point inside a block, interpolated from the block azimuths by firing time
// (lidar::AzimuthInterpolation). kPerLaser (default) interpolates each laser by its own firing
// time, as the manuals' precision-azimuth formula and the ROS driver; kPerSequence is VeloView's
// convention (a VLP-16 block's second firing sequence half a block later, every other laser at
// its block azimuth), up to ~0.3° different at 20 Hz. Per-point time `t` is per laser in both.
using AzimuthInterpolation = lidar::AzimuthInterpolation;

struct DecoderConfig {
  Model model = Model::kVLP16;
  std::optional<Calibration> calibration;  // nullopt: the model's built-in manual values
  ReturnSelection returns = ReturnSelection::kStrongest;
  AzimuthInterpolation interpolation = AzimuthInterpolation::kPerLaser;
  double min_range_m = 0.0;                // points closer are dropped (zero distance always is)
  double max_range_m = std::numeric_limits<double>::infinity();
  double cut_angle_deg = 0.0;              // a scan ends when the azimuth crosses this; 0 = wrap
  // The scan before the first cut starts mid-rotation: emitted only when this is set
  // (VeloView numbers it frame 0). A scan interrupted by a time jump is partial too.
  bool emit_partial_scans = false;
  // A packet time more than this after the previous one (or any step back > 1 ms) ends the
  // current scan as partial: t stays meaningful and a sensor clock reset cannot stall the decoder.
  Nanos max_packet_gap_ns = 1'000'000'000;
  // The sensor's own FOV setting (it sends only this clockwise arc); start == end: the whole turn.
  // Only gaps inside it count as missing packets.
  double fov_start_deg = 0.0;
  double fov_end_deg = 0.0;
  // Points reserved for the first scan buffers; 0: the model's typical scan (twice with kDual).
  // Later scans reserve the last scan's size. A small value costs only reallocations as a scan
  // grows (the fuzz harnesses: a decoder per input, no multi-MB reserve each).
  std::size_t first_scan_reserve_points = 0;
};

inline constexpr std::size_t kStatusCount = kPacketStatusCount;

struct DecoderStats : ScanStats {
  std::uint64_t early_cut_misses = 0;  // scans ended at a packet's end whose next block did not cross
  std::uint64_t corrupt_blocks = 0;    // blocks off their packet's azimuth line: not decoded (implausible_steps)
};

struct DecoderImpl;

class Decoder : public DecoderPimpl<DecoderImpl, DecoderConfig, DecoderStats> {
 public:
  explicit Decoder(DecoderConfig config);  // throws CalibrationError / std::invalid_argument

  // Ring (0 = lowest elevation) of each laser id, from the calibration.
  [[nodiscard]] std::uint16_t ring_of_laser(int laser_id) const noexcept;
};

// Checks size, block flags, azimuths and the factory bytes against `m` without decoding.
// Product id 0x21 (HDL-32E) is accepted for every model: early VLP-16 firmware sent it too.
PacketStatus check_packet(std::span<const std::byte> bytes, Model m) noexcept;

}  // namespace sensor_rig::lidar::velodyne

namespace sensor_rig::lidar {
extern template class DecoderPimpl<velodyne::DecoderImpl, velodyne::DecoderConfig, velodyne::DecoderStats>;
}  // namespace sensor_rig::lidar
