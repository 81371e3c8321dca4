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
#include <memory>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar::hesai {

// Which echoes to keep from dual-return packets (single-return packets keep their one echo).
// kStrongest: the echo with the higher reflectivity (the first block on a tie). kLast: the last
// echo (the farther one when the mode has no last echo). kDual: both, except that an echo
// identical to the other one, or closer than dual_distance_threshold_m to it, is kept once
// (the second block's), as nebula does.
enum class ReturnSelection : std::uint8_t { kStrongest, kLast, kDual };

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
};

inline constexpr std::size_t kStatusCount = 7;  // PacketStatus values

struct DecoderStats {
  std::uint64_t packets = 0;       // pushed
  std::uint64_t packets_used = 0;  // decoded into points
  std::array<std::uint64_t, kStatusCount> by_status{};  // indexed by PacketStatus
  std::uint64_t scans = 0;         // emitted
  std::uint64_t partial_scans_discarded = 0;
  std::uint64_t time_jumps = 0;    // scans ended early because the packet time jumped
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

  // Decodes one data packet; returns the scan it completed, if any. Never throws: a rejected
  // packet is counted (stats(), the scan's `dropped`) and last_status() says why.
  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept;
  // The scan in progress (partial), if it has packets; resets (points held for the next scan are
  // discarded).
  std::optional<Scan> flush() noexcept;
  // A published scan's point buffer back for reuse.
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept;

  // Offset of a packet's first firing from its tail time with this decoder's firing times (< 0).
  [[nodiscard]] Nanos first_firing_offset_ns(int returns) const noexcept;
  // Echoes per azimuth of the last valid packet (before any: 2 if dual was selected, else 1).
  [[nodiscard]] int last_returns() const noexcept;
  [[nodiscard]] PacketStatus last_status() const noexcept;
  [[nodiscard]] const DecoderStats& stats() const noexcept;
  [[nodiscard]] const DecoderConfig& config() const noexcept;
  // Ring (0 = lowest elevation) of a channel (1-based, as in the calibration file).
  [[nodiscard]] std::uint16_t ring_of_channel(int channel) const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::lidar::hesai
