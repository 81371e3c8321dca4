#pragma once
// Synthetic Hesai sensor (Pandar40P, PandarXT32): renders a Scene into genuine data packets with
// the layouts of hesai/packet.hpp (40P: 10 blocks x 40 channels + 22-byte tail; XT32: header,
// 8 blocks x 32 channels, tail, UDP sequence), the model's firing timing from hesai::ModelInfo
// (one azimuth group every group_period_ns: 55.56 µs / 50 µs) and the channel firing offsets and
// angle corrections of the decoder's tables (or a given calibration / Firetime table).
// Pure: time is an input, no I/O, no clock reads.
//
// Timing (the decoder's model, read backwards): azimuth group k has the reference time
// g_k = start + k * group_period; channel c fires at g_k + firing_us[c]. A packet holds G groups
// (G = blocks / echoes); its tail time is g_last - tail_to_last_group_ns, written as UTC date/time
// + µs (vehicle time, as a PTP-synced sensor). The block azimuth is the rotor angle at g_k
// (0.01°); each channel's ray is the rotor angle at its own firing time plus its azimuth offset,
// at its elevation (the vendor SDK's firetime correction; a decoder that ignores it is off by
// rpm x firing offset, up to ~0.2° at 600 rpm). Distances are quantized to the model's 4 mm.
// Dual modes (e.g. 0x39 last + strongest): each group as two blocks with the same echo.
// SyntheticPacket::time_ns is when the packet is complete (its tail time or last firing, the later).
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"
#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"

namespace sensor_rig::lidar::mock {

struct SyntheticHesaiConfig {
  hesai::Model model = hesai::Model::kPandar40P;
  double rpm = 600.0;                                 // Pandar40P: 600 or 1200; PandarXT32: 300, 600, 1200
  // Any mode of hesai::ReturnMode; dual modes carry the scene's one echo in both blocks.
  hesai::ReturnMode return_mode = hesai::ReturnMode::kStrongest;
  Nanos start_ns = 0;                                 // vehicle time of group 0's reference time
  double start_azimuth_deg = 0.0;                     // rotor angle then (clockwise from the front)
  std::optional<hesai::Calibration> calibration;      // nullopt: the decoder's built-in angles
  std::optional<hesai::FiringTimes> firing_times;     // nullopt: the decoder's built-in Firetime table
  bool udp_sequence = false;                          // Pandar40P: append the 4-byte UDP sequence
  double max_range_m = 200.0;
};

// Empty when the model runs at `rpm`, else why not (for config validation and the CLI).
std::string hesai_rpm_error(hesai::Model m, double rpm);

class SyntheticHesai final : public SyntheticSensor {
 public:
  // Throws std::invalid_argument (rpm, calibration size).
  SyntheticHesai(SyntheticHesaiConfig config, Scene scene);

  [[nodiscard]] const SyntheticHesaiConfig& config() const noexcept { return config_; }
  [[nodiscard]] const Scene& scene() const noexcept { return scene_; }
  [[nodiscard]] std::size_t packet_size() const noexcept { return packet_size_; }
  [[nodiscard]] int groups_per_packet() const noexcept { return groups_; }
  [[nodiscard]] double packet_period_ns() const noexcept;
  [[nodiscard]] double packets_per_second() const noexcept override { return 1e9 / packet_period_ns(); }
  [[nodiscard]] Nanos group_time(std::uint64_t group) const noexcept;   // reference time g_k
  [[nodiscard]] Nanos tail_time(std::uint64_t packet) const noexcept;   // what the tail says (ns)
  [[nodiscard]] Nanos first_firing(std::uint64_t packet) const noexcept;
  // When the packet is complete and sent: its tail time or its last firing, the later.
  [[nodiscard]] Nanos complete_time(std::uint64_t packet) const noexcept;
  [[nodiscard]] double azimuth_deg_at(Nanos t) const noexcept;          // rotor angle, [0, 360)
  // Rotation (degrees) between a group's reference time and channel c's (0-based) firing.
  [[nodiscard]] double firing_rotation_deg(int channel) const noexcept;

  void render_packet(std::uint64_t index, std::span<std::byte> out) const noexcept;
  SyntheticPacket next() override;
  [[nodiscard]] Nanos first_packet_offset_ns() const noexcept override;
  void set_start_ns(Nanos start_ns) noexcept override { config_.start_ns = start_ns; }
  [[nodiscard]] double rotation_period_ns() const noexcept override { return 360.0 / deg_per_ns_; }
  [[nodiscard]] double start_rotor_deg() const noexcept override { return config_.start_azimuth_deg; }
  [[nodiscard]] UnitRule unit_rule() const noexcept override;
  [[nodiscard]] std::uint64_t packets_emitted() const noexcept { return next_; }

 private:
  struct Channel {
    double sin_el, cos_el, azimuth_offset_deg;
    Nanos fire_ns;
  };

  SyntheticHesaiConfig config_;
  Scene scene_;
  const hesai::ModelInfo* mi_;
  std::vector<Channel> channels_;
  std::size_t packet_size_ = 0;
  int echoes_ = 1;
  int groups_ = 0;
  double deg_per_ns_ = 0;
  Nanos max_fire_ns_ = 0;
  Nanos min_fire_ns_ = 0;
  std::uint64_t next_ = 0;
  std::vector<std::byte> buf_;
};

}  // namespace sensor_rig::lidar::mock
