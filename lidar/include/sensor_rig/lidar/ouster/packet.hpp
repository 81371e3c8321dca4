#pragma once
// Bounds-checked reads of one Ouster lidar packet laid out by a PacketLayout. Every accessor takes
// the whole payload and checks its size first; none throws. The decoder's hot loop reads through
// the same FieldReaders after one check_packet().
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "sensor_rig/lidar/ouster/profile.hpp"
#include "sensor_rig/lidar/packet.hpp"

namespace sensor_rig::lidar::ouster {

// Packet header (non-legacy; LEGACY packets report the first column's frame id and zeros).
struct PacketHeader {
  std::uint16_t packet_type = 0;
  std::uint32_t frame_id = 0;
  std::uint32_t init_id = 0;
  std::uint64_t prod_sn = 0;
  std::uint8_t alert_flags = 0;
  std::uint8_t countdown_thermal_shutdown = 0;
  std::uint8_t countdown_shot_limiting = 0;
  std::uint8_t thermal_shutdown = 0;
  std::uint8_t shot_limiting = 0;
};

// Column (measurement block) header.
struct ColumnHeader {
  std::uint64_t timestamp_ns = 0;  // sensor clock (PTP, GPS, sync pulse or internal oscillator)
  std::uint16_t measurement_id = 0;  // column index within the frame, 0..columns_per_frame-1
  std::uint32_t status = 0;          // LEGACY: 32 bits (0xFFFFFFFF valid); others: 16 bits
  std::uint32_t encoder_count = 0;   // LEGACY only
  std::uint16_t frame_id = 0;        // LEGACY only (others: packet header)
  [[nodiscard]] bool valid() const noexcept { return (status & 1U) != 0; }
};

// kWrongSize unless the payload is exactly layout.packet_size; kNotData for a non-legacy packet
// whose packet_type is not the lidar type (0x1). Otherwise kOk.
PacketStatus check_packet(std::span<const std::byte> bytes, const PacketLayout& layout) noexcept;

// nullopt unless the payload has exactly layout.packet_size bytes (and col < columns_per_packet).
std::optional<PacketHeader> read_packet_header(std::span<const std::byte> bytes, const PacketLayout& layout) noexcept;
std::optional<ColumnHeader> read_column_header(std::span<const std::byte> bytes, const PacketLayout& layout,
                                               std::size_t col) noexcept;
// One pixel field; nullopt when out of bounds or the profile does not carry the field.
std::optional<std::uint64_t> read_field(std::span<const std::byte> bytes, const PacketLayout& layout,
                                        std::size_t col, std::size_t px, Field f) noexcept;

// Unchecked column header read for the hot loop: `col_ptr` points at a column inside a packet that
// passed check_packet().
ColumnHeader column_header_at(const std::uint8_t* col_ptr, const PacketLayout& layout) noexcept;
// Frame id of a packet that passed check_packet() (LEGACY: the first column's).
std::uint32_t frame_id_at(const std::uint8_t* packet, const PacketLayout& layout) noexcept;

}  // namespace sensor_rig::lidar::ouster
