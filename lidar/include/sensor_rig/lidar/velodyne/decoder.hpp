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
#include <memory>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"

namespace sensor_rig::lidar::velodyne {

// Which echoes to keep. Dual-return packets carry pairs of blocks (last, strongest-or-second);
// single-return packets carry one echo, which is kept whatever is selected here.
enum class ReturnSelection : std::uint8_t { kStrongest, kLast, kDual };

// Azimuth of a point inside a block, interpolated from the block azimuths by firing time.
// kPerSequence is VeloView's (and Velodyne's reference) convention: a VLP-16 block's second
// firing sequence is half a block later, every other laser uses its block azimuth. kPerLaser also
// interpolates each laser's firing time (as the ROS driver does for the VLP-16), up to ~0.3°
// different at 20 Hz. Per-point time `t` is per laser in both cases.
enum class AzimuthInterpolation : std::uint8_t { kPerSequence, kPerLaser };

struct DecoderConfig {
  Model model = Model::kVLP16;
  std::optional<Calibration> calibration;  // nullopt: the model's built-in manual values
  ReturnSelection returns = ReturnSelection::kStrongest;
  AzimuthInterpolation interpolation = AzimuthInterpolation::kPerSequence;
  double min_range_m = 0.0;                // points closer are dropped (zero distance always is)
  double max_range_m = std::numeric_limits<double>::infinity();
  double cut_angle_deg = 0.0;              // a scan ends when the azimuth crosses this; 0 = wrap
  // The scan before the first cut starts mid-rotation: emitted only when this is set
  // (VeloView numbers it frame 0). A scan interrupted by a time jump is partial too.
  bool emit_partial_scans = false;
  // A packet time more than this after the previous one (or any step back > 1 ms) ends the
  // current scan as partial: t stays meaningful and a sensor clock reset cannot stall the decoder.
  Nanos max_packet_gap_ns = 1'000'000'000;
};

inline constexpr std::size_t kStatusCount = 7;  // PacketStatus values

struct DecoderStats {
  std::uint64_t packets = 0;           // pushed
  std::uint64_t packets_used = 0;      // decoded into points
  std::array<std::uint64_t, kStatusCount> by_status{};  // indexed by PacketStatus
  std::uint64_t scans = 0;             // emitted
  std::uint64_t partial_scans_discarded = 0;
  std::uint64_t time_jumps = 0;        // scans ended early because the packet time jumped
  std::uint64_t early_cut_misses = 0;  // scans ended at a packet's end whose next block did not cross
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

  // Decodes one data packet. Returns the scan the packet completed, if any. Never throws;
  // a rejected packet is counted (stats(), the scan's `dropped`) and last_status() says why.
  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept;
  // Returns the scan in progress (partial) and resets; nullopt if it has no packets.
  std::optional<Scan> flush() noexcept;
  // Hands a published scan's point buffer back for reuse (optional): the next scan writes into it
  // instead of a fresh allocation, which saves the page faults of a new multi-MB buffer per scan.
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept;

  [[nodiscard]] PacketStatus last_status() const noexcept;
  [[nodiscard]] const DecoderStats& stats() const noexcept;
  [[nodiscard]] const DecoderConfig& config() const noexcept;
  // Ring (0 = lowest elevation) of each laser id, from the calibration.
  [[nodiscard]] std::uint16_t ring_of_laser(int laser_id) const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Checks size, block flags, azimuths and the factory bytes against `m` without decoding.
// Product id 0x21 (HDL-32E) is accepted for every model: early VLP-16 firmware sent it too.
PacketStatus check_packet(std::span<const std::byte> bytes, Model m) noexcept;

}  // namespace sensor_rig::lidar::velodyne
