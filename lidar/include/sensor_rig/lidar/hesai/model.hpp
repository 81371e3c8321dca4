#pragma once
// Hesai models as data: one field table per packet layout (byte offsets taken from the packet
// types), firing-time constants from the user manuals, and what a packet says about itself.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/packet.hpp"

namespace sensor_rig::lidar::hesai {

enum class Model : std::uint8_t { kPandar40P, kPandarXT32 };

struct ModelInfo {
  std::string_view name;            // SPEC §7 name
  int channels;
  int blocks;                       // blocks per packet
  std::size_t packet_size;          // UDP payload
  std::size_t packet_size_alt;      // also accepted (Pandar40P with the UDP sequence), 0 = none
  std::size_t first_block;          // byte offset of block 0
  std::size_t block_size;
  std::size_t block_azimuth;        // offset of the azimuth inside a block
  std::size_t block_units;          // offset of unit 0 inside a block
  std::size_t unit_size;
  std::size_t tail_return_mode;     // byte offsets from the packet start
  std::size_t tail_utc;
  std::size_t tail_timestamp;
  int year_offset;                  // UTC year field + this = year
  double distance_unit_m;           // Pandar40P fixed; XT32 reads HeaderXT::dis_unit (this is the default)
  // Firing times (ns), relative to the tail timestamp T: azimuth group g of G groups per packet
  // (G = blocks / echoes) fires channel c at T + tail_to_last_group_ns - group_period_ns * (G-1-g)
  // + firing offset of c (firing_time_us table, the vendor's Firetime CSV).
  std::int32_t group_period_ns;
  std::int32_t tail_to_last_group_ns;
  std::span<const double> firing_us;  // per channel (0-based), built-in
  int typical_points_per_scan;        // single return at 10 Hz, for buffer sizing
};

const ModelInfo& model_info(Model m) noexcept;
std::optional<Model> model_from_name(std::string_view name) noexcept;

// Checks size, start-of-block / start-of-packet marks, header counts, azimuths and the return
// mode byte without decoding. Never throws.
PacketStatus check_packet(std::span<const std::byte> bytes, Model m) noexcept;

// What a valid data packet says about itself.
struct PacketInfo {
  std::uint8_t return_mode = 0;
  int returns = 1;                     // echoes per azimuth (1 or 2)
  std::optional<Nanos> tail_time_ns;   // UTC date/time + µs (sensor clock); nullopt if the date is invalid
};
// nullopt unless check_packet() is kOk.
std::optional<PacketInfo> read_packet_info(std::span<const std::byte> bytes, Model m) noexcept;

// Offset of a packet's first firing from its tail time with the built-in firing times, for
// `returns` echoes per azimuth (negative: the tail time is at the end of the packet).
Nanos first_firing_offset_ns(Model m, int returns) noexcept;

}  // namespace sensor_rig::lidar::hesai
