#pragma once
// Velodyne models the decoder knows: packet layout per model, firing timing (user manuals) and
// defaults. A registry maps the CLI/config names to models so more models can be added in one place.
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::velodyne {

enum class Model : std::uint8_t { kVLP16, kVLP32C, kHDL32E };

struct ModelInfo {
  Model model;
  std::string_view name;           // as on the command line: "VLP-16"
  ProductId product_id;            // factory byte 2 of the packet trailer
  int lasers;                      // physical lasers; a block holds 32 / lasers firing sequences
  double block_us;                 // duration of one block (single return) in µs
  double channel_us;               // spacing between firings (or firing groups) in µs
  double distance_resolution_m;    // default metres per distance count
  double max_range_m;              // manual's rated range (for sanity checks, not filtering)
  int typical_points_per_scan;     // single return, 10 Hz; used to reserve scan buffers
};

// Every model in the registry, in a fixed order.
std::span<const ModelInfo> all_models() noexcept;
const ModelInfo& model_info(Model m) noexcept;
// Looks up a CLI/config name (case-sensitive, as SPEC §7 spells them); nullopt if unknown.
std::optional<Model> model_from_name(std::string_view name) noexcept;

// Firing time of channel `c` (0..31) of a block relative to the block's first firing, in ns.
// VLP-16: two 16-laser sequences of 55.296 µs per block, lasers 2.304 µs apart.
// VLP-32C: 16 firing groups of two lasers, 2.304 µs apart. HDL-32E: 32 lasers 1.152 µs apart.
std::uint32_t channel_offset_ns(Model m, int channel) noexcept;
// Laser id of block channel `c` (VLP-16: c % 16, others: c).
int channel_laser(Model m, int channel) noexcept;

}  // namespace sensor_rig::lidar::velodyne
