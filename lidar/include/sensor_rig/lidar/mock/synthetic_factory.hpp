#pragma once
// One entry point for every synthetic LIDAR: the model name (SPEC §7) picks the vendor's renderer.
// Used by `rig lidar replay --synthetic MODEL` and by `rig up` (config validation, and the Ouster
// metadata the driver and its mock share). Pure: no I/O (texts in), no clock reads.
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/return_selection.hpp"

namespace sensor_rig::lidar::mock {

struct SyntheticOptions {
  std::string model;                  // VLP-16, VLP-32C, HDL-32E, OS-LEGACY, OS, Pandar40P, PandarXT32
  double rpm = 600.0;                 // Ouster: 600 (x10 modes) or 1200 (x20 modes) when no metadata is given
  ReturnSelection returns = ReturnSelection::kStrongest;  // Velodyne, Hesai; Ouster renders one echo
  Nanos start_ns = 0;                 // vehicle time the sensor's timeline starts at
  // Rotor angle at every whole second (phase_lock.hpp); nullopt: free running from start_ns. The
  // sender applies it (phase_locked_start_ns); the factory only checks that the sensor can lock.
  std::optional<double> phase_lock_deg;
  std::string calibration_text;       // Velodyne ROS YAML / VeloView XML, Hesai angle or Firetime CSV
  std::string calibration_name;
  std::string metadata_text;          // Ouster: the sensor's metadata JSON; empty = nominal OS-1
  std::string metadata_name;
  int ouster_beams = 32;              // nominal Ouster only
  std::string ouster_mode;            // nominal Ouster: lidar mode; empty = 1024x(rpm/60)
  std::string ouster_profile;         // nominal OS: UDP profile; empty = RNG19_RFL8_SIG16_NIR16
  std::uint16_t ouster_udp_port = 7502;  // nominal Ouster: udp_port_lidar (imu = +1)
  Nanos ouster_imu_period_ns = 10'000'000;  // Ouster IMU packets (flagged position: the second port); 0 = none
  // Where the rotor starts (SyntheticSensor::start_rotor_deg; Ouster: rounded to a packet's first
  // column) and how often the sensor has restarted (Ouster: the init_id it sends changes with it):
  // the sensor faults (sensor_faults.hpp) start a sensor again mid-run with these.
  double start_rotor_deg = 0.0;
  std::uint32_t boot = 0;
};

// "VLP-16, VLP-32C, HDL-32E, OS-LEGACY, OS, Pandar40P, PandarXT32".
std::string synthetic_model_names();
bool is_synthetic_model(std::string_view model) noexcept;

// Throws std::invalid_argument naming the problem (unknown model, rpm the model cannot run at,
// bad calibration or metadata, metadata profile not of the model, a phase lock it cannot hold).
std::unique_ptr<SyntheticSensor> make_synthetic_sensor(const SyntheticOptions& o, Scene scene);

// Empty when a synthetic sensor of these options can be made, else why not (as the exception of
// make_synthetic_sensor would say); cheap enough for config validation.
std::string synthetic_options_error(const SyntheticOptions& o);

// The metadata the synthetic Ouster of these options renders with: parsed from metadata_text, or
// the nominal OS-1. Throws std::invalid_argument as above (also for a non-Ouster model).
ouster::SensorMetadata synthetic_ouster_metadata(const SyntheticOptions& o);
bool is_ouster_model(std::string_view model) noexcept;

}  // namespace sensor_rig::lidar::mock
