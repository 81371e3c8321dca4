#pragma once
// Synthetic Velodyne sensor: renders a Scene into genuine data packets of the configured model
// (VLP-16, VLP-32C, HDL-32E) with the model's firing timing and packet rate (12 blocks per packet,
// block durations from the user manuals via velodyne::model_info), the azimuth progression of the
// configured rpm, the per-laser geometry of a calibration (the decoder's built-in manual values by
// default), distances quantized to the model's resolution, reflectivity as intensity, the sensor
// timestamp (µs since the top of the hour), return-mode and product-id bytes; plus position
// packets with a $GPRMC sentence. Pure: time is an input, no I/O, no clock reads.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"
#include "sensor_rig/lidar/velodyne/packet.hpp"
#include "sensor_rig/lidar/velodyne/position_packet.hpp"

namespace sensor_rig::lidar::mock {

struct SyntheticConfig {
  velodyne::Model model = velodyne::Model::kVLP16;
  double rpm = 600.0;                                       // 300..1200 as the sensors allow
  velodyne::ReturnMode return_mode = velodyne::ReturnMode::kStrongest;
  Nanos start_ns = 0;                                       // vehicle time of the first firing
  double start_azimuth_deg = 0.0;
  std::optional<velodyne::Calibration> calibration;         // nullopt: default_calibration(model)
  Nanos position_period_ns = 1'000'000'000;                 // 0: no position packets
  velodyne::PpsState pps = velodyne::PpsState::kLocked;
  bool gps_fix_valid = true;
};

// SyntheticPacket::time_ns: vehicle time of a data packet's first firing (or of the GPS report).
class SyntheticVelodyne final : public SyntheticSensor {
 public:
  // Throws std::invalid_argument (rpm out of range) or velodyne::CalibrationError.
  SyntheticVelodyne(SyntheticConfig config, Scene scene);

  [[nodiscard]] const SyntheticConfig& config() const noexcept { return config_; }
  [[nodiscard]] const Scene& scene() const noexcept { return scene_; }
  // Data packet period: 12 blocks; dual return carries each firing twice, so half the duration.
  [[nodiscard]] double packet_period_ns() const noexcept { return packet_period_ns_; }
  [[nodiscard]] double packets_per_second() const noexcept override { return 1e9 / packet_period_ns_; }
  [[nodiscard]] Nanos data_packet_time(std::uint64_t index) const noexcept;
  [[nodiscard]] double azimuth_deg_at(Nanos t) const noexcept;  // 0..360, the sensor's convention

  // Renders data packet `index` (time data_packet_time(index)).
  void render_data_packet(std::uint64_t index, std::span<std::byte, velodyne::kDataPacketSize> out) const noexcept;
  // Position packet reporting vehicle time t (µs since hour, GPRMC of the last whole second).
  void render_position_packet(Nanos t, std::span<std::byte, velodyne::kPositionPacketSize> out) const;

  // The merged stream: data packets and, every position_period_ns, a position packet.
  SyntheticPacket next() override;
  [[nodiscard]] Nanos first_packet_offset_ns() const noexcept override { return 0; }  // first firing or GPS report
  void set_start_ns(Nanos start_ns) noexcept override { config_.start_ns = start_ns; }
  [[nodiscard]] double rotation_period_ns() const noexcept override { return 360.0 / deg_per_ns_; }
  [[nodiscard]] double start_rotor_deg() const noexcept override { return config_.start_azimuth_deg; }
  [[nodiscard]] UnitRule unit_rule() const noexcept override { return {UnitRule::Kind::kAzimuthCut, 0, 0}; }
  [[nodiscard]] std::uint64_t data_packets_emitted() const noexcept { return next_data_; }
  [[nodiscard]] std::uint64_t position_packets_emitted() const noexcept { return next_position_; }

 private:
  struct Laser {
    double sin_v, cos_v;       // elevation
    double rot_rad;            // subtracted from the azimuth
    double dist_correction;    // m
    double vert_offset, horiz_offset;
  };

  // Block f of the packet whose first firing is t0: its first firing and azimuth field (0.01°).
  [[nodiscard]] Nanos block_time(Nanos t0, std::size_t f) const noexcept;
  [[nodiscard]] std::uint16_t azimuth_raw(Nanos t) const noexcept;
  [[nodiscard]] std::uint16_t raw_distance(const Laser& l, double azimuth_rad, std::uint8_t& intensity) const noexcept;

  SyntheticConfig config_;
  Scene scene_;
  velodyne::ModelInfo info_;
  std::vector<Laser> lasers_;
  std::array<std::uint32_t, velodyne::kChannelsPerBlock> channel_ns_{};
  std::array<int, velodyne::kChannelsPerBlock> channel_laser_{};
  double resolution_m_ = 0.002;
  double max_range_m_ = 100.0;
  double packet_period_ns_ = 0;
  double block_ns_ = 0;
  double deg_per_ns_ = 0;
  bool dual_ = false;
  std::uint64_t next_data_ = 0;
  std::uint64_t next_position_ = 0;
  std::array<std::byte, velodyne::kDataPacketSize> data_buf_{};
  std::array<std::byte, velodyne::kPositionPacketSize> pos_buf_{};
};

}  // namespace sensor_rig::lidar::mock
