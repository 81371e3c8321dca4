#pragma once
// Synthetic Ouster sensor: renders a Scene into genuine lidar packets of any UDP profile the
// decoder knows (LEGACY and the eUDP profiles of ouster/profile.hpp), laid out by the metadata's
// PacketLayout and written through the same field tables the decoder reads. Geometry is the
// metadata's (beam altitude/azimuth angles, lidar origin to beam origin, lidar to sensor
// transform: ouster-sdk's projection, which the decoder's lookup table implements); timing is the
// lidar mode's (W columns per frame at F Hz: a column every 1/(W F) s, columns_per_packet per
// packet). Pure: time is an input, no I/O, no clock reads.
//
// Column timestamps are vehicle time in ns (a PTP-synced sensor's TIME_FROM_PTP_1588). Column j of
// frame f fires at start + ((f W + j) - start_column) / (W F); measurement id j, encoder count
// j * 90112 / W, frame id f (16 bits), status valid inside the column window (else zero data and
// status 0, as the sensor sends them). Pixels: range in mm (the profile's units) along the ray from
// the beam's projection origin, reflectivity = the surface's, signal = reflectivity * 4000 / r^2
// photons (r in m, at least 1 m), near-IR 100; no return: all zero.
// SyntheticPacket::time_ns: when the packet is complete (its last column's period has ended; the
// decoder's packet_span_ns() after the first column), i.e. when the sensor sends it.
// IMU packets (ouster/imu_packet.hpp, the legacy 48-byte layout) every imu_period_ns, interleaved
// in time order and flagged `position` (they go to the second port, udp_port_imu): the first at
// the first lidar packet's time (after it), then every period; all three timestamps = the packet's
// time_ns; a still sensor: acceleration and angular velocity as configured (default +1 g on z).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/ouster/profile.hpp"

namespace sensor_rig::lidar::mock {

// A nominal OS-1 (the sensor a fresh clone has no metadata for).
struct NominalOuster {
  int beams = 32;                          // 16, 32, 64 or 128 (OS-1-<beams>)
  std::string lidar_mode = "1024x10";      // 512x10, 1024x10, 2048x10, 512x20, 1024x20, 4096x5
  ouster::Profile profile = ouster::Profile::kLegacy;
  std::uint16_t udp_port_lidar = 7502;
  std::uint16_t udp_port_imu = 7503;
};

// Uniform beams over the OS-1's 33.2° (+16.6° .. -16.6°), azimuth offsets in the 4-column stagger
// (+4.23, +1.41, -1.41, -4.23°), lidar origin to beam origin 15.806 mm, lidar to sensor transform
// of the OS-1 (rotated 180° about z, 36.18 mm up). Throws std::invalid_argument on a bad beam count
// or lidar mode.
ouster::SensorMetadata nominal_ouster_metadata(const NominalOuster& n);
// The metadata as the flat JSON (FW 2.x, with data_format) that ouster::parse_metadata reads back
// to the same values.
std::string metadata_json(const ouster::SensorMetadata& m);
// "1024x10" -> true when it is one of the sensor's lidar modes.
bool is_ouster_lidar_mode(const std::string& mode) noexcept;

struct SyntheticOusterConfig {
  ouster::SensorMetadata metadata;   // e.g. nominal_ouster_metadata() or parse_metadata(file)
  Nanos start_ns = 0;                // vehicle time of the first column rendered
  int start_column = 0;              // its measurement id
  std::uint32_t first_frame_id = 0;
  double max_range_m = 120.0;        // farther hits read as no return
  Nanos imu_period_ns = 0;           // IMU packets every this long (100 Hz on the sensor: 10 ms); 0 = none
  std::array<float, 3> imu_accel_g{0.0F, 0.0F, 1.0F};
  std::array<float, 3> imu_gyro_dps{0.0F, 0.0F, 0.0F};
};

class SyntheticOuster final : public SyntheticSensor {
 public:
  // Throws std::invalid_argument (metadata not usable, start_column outside the frame).
  SyntheticOuster(SyntheticOusterConfig config, Scene scene);

  [[nodiscard]] const SyntheticOusterConfig& config() const noexcept { return config_; }
  [[nodiscard]] const ouster::PacketLayout& layout() const noexcept { return layout_; }
  [[nodiscard]] const Scene& scene() const noexcept { return scene_; }
  [[nodiscard]] double column_period_ns() const noexcept { return column_ns_; }
  [[nodiscard]] double packets_per_second() const noexcept override;
  // Vehicle time of the first column of packet `index`.
  [[nodiscard]] Nanos packet_time(std::uint64_t index) const noexcept;

  // Renders packet `index` into `out` (layout().packet_size bytes).
  void render_packet(std::uint64_t index, std::span<std::byte> out) const noexcept;
  SyntheticPacket next() override;
  [[nodiscard]] Nanos first_packet_offset_ns() const noexcept override;
  void set_start_ns(Nanos start_ns) noexcept override { config_.start_ns = start_ns; }
  [[nodiscard]] double rotation_period_ns() const noexcept override {
    return column_ns_ * config_.metadata.columns_per_frame;
  }
  [[nodiscard]] double start_rotor_deg() const noexcept override {
    return 360.0 * config_.start_column / config_.metadata.columns_per_frame;
  }
  [[nodiscard]] UnitRule unit_rule() const noexcept override { return {UnitRule::Kind::kFrame, 0, 0}; }
  [[nodiscard]] std::uint64_t packets_emitted() const noexcept { return next_; }
  [[nodiscard]] std::uint64_t imu_packets_emitted() const noexcept { return imu_next_; }

 private:
  struct Ray {
    Vec3 origin, dir;  // sensor frame, metres, unit direction
  };
  [[nodiscard]] Nanos column_time(std::uint64_t column) const noexcept;

  SyntheticOusterConfig config_;
  Scene scene_;
  ouster::PacketLayout layout_;
  std::vector<Ray> rays_;  // column-major: rays_[mid * pixels + beam]
  double column_ns_ = 0;
  std::uint64_t next_ = 0;
  std::uint64_t imu_next_ = 0;
  std::vector<std::byte> buf_;
  std::vector<std::byte> imu_buf_;
};

}  // namespace sensor_rig::lidar::mock
