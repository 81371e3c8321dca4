#pragma once
// Where a named field lies in a synthetic sensor's data packets, per vendor, for the faults that
// change one field (lidar.corrupt field=..., lidar.stuck_azimuth): the fault vocabulary's generic
// names mapped onto each vendor's real packet field. Pure: bytes in, bytes out.
//
//   field          Velodyne                 Hesai                          Ouster
//   time           trailer µs since hour    tail µs (40P/XT32)             first column's timestamp
//   azimuth        first block's azimuth    first block's azimuth          first column's measurement id
//   frame_id       (none: refused)          (none: refused)                frame id (LEGACY: first column's)
//   column_status  first block's FF EE flag 40P: first block's FF EE flag  first column's status
//                                           XT32: (none: refused)
//   udp_seq        (none: refused)          the UDP sequence (XT32; 40P     (none: refused)
//                                           only with the sequence)
//   byte           any byte (offset, or a random one)
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"

namespace sensor_rig::lidar::mock {

enum class PacketField : std::uint8_t { kTime, kAzimuth, kFrameId, kColumnStatus, kUdpSeq, kByte };
std::optional<PacketField> packet_field_from_name(std::string_view name) noexcept;
std::string_view to_string(PacketField f) noexcept;

struct FieldBytes {
  std::size_t offset = 0;
  std::size_t size = 0;
};

class PacketFields {
 public:
  // The layout of `sensor`'s data packets (any of the three vendors' synthetic sensors).
  explicit PacketFields(const SyntheticSensor& sensor);

  // Where `f` lies (kByte: offset `byte_offset` when >= 0). Throws std::invalid_argument naming
  // the model and the field when its packets have no such field.
  [[nodiscard]] FieldBytes locate(PacketField f, long byte_offset = -1) const;
  // Stuck encoder: every azimuth field of the packet (Velodyne/Hesai blocks, Ouster measurement
  // ids and LEGACY encoder counts) set to the value the first one has in `frozen`.
  void freeze_azimuth(std::span<std::byte> packet, std::span<const std::byte> frozen) const noexcept;
  [[nodiscard]] const std::string& model() const noexcept { return model_; }
  [[nodiscard]] std::size_t packet_size() const noexcept { return packet_size_; }

 private:
  enum class Vendor : std::uint8_t { kVelodyne, kHesai, kOuster } vendor_ = Vendor::kVelodyne;
  std::string model_;
  std::size_t packet_size_ = 0;
  // Azimuth fields: count, first offset, stride, width (Ouster: the measurement id per column).
  std::size_t az_count_ = 0, az_offset_ = 0, az_stride_ = 0;
  std::optional<FieldBytes> time_, frame_, status_, seq_;
  std::size_t encoder_offset_ = 0;  // Ouster LEGACY: encoder count of the first column (0 = none)
};

}  // namespace sensor_rig::lidar::mock
