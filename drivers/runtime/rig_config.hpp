#pragma once
// The rig's YAML configuration (config/*.yaml) as plain structs with defaults, validated on load:
// unknown keys, wrong types and bad values fail before anything starts, naming file:line and key.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::runtime {

// How the LIDAR's mock (started by `rig up` beside the driver) produces packets.
struct LidarMockConfig {
  enum class Kind { kNone, kSynthetic, kReplay } kind = Kind::kNone;
  std::string pcap;          // replay: capture file (falls back to synthetic when absent and optional)
  double rate = 1.0;         // replay speed factor
  bool loop = true;
  int rpm = 600;             // synthetic: rotation speed
  double drop_rate = 0.0;    // fault injection, passed to `rig lidar replay`
  double corrupt_rate = 0.0;
};

inline dds::QosSpec lidar_qos() {
  dds::QosSpec q;
  q.depth = 2;
  return q;
}

struct LidarConfig {
  std::string name;                    // topic /sensors/lidar/<name>/points
  std::string model;                   // a model of the decoder registry (lidar/scan_decoder.hpp)
  std::string host = "127.0.0.1";      // bind address
  int port = 2368;                     // data port
  int position_port = 0;               // 0 = none (position packets ignored)
  int receive_buffer_bytes = 8 << 20;
  std::string calibration;             // empty = model defaults
  std::string metadata;                // sensor metadata JSON (Ouster)
  std::string returns = "strongest";   // strongest | last | dual
  double min_range_m = 0.4;
  double max_range_m = 200.0;
  double cut_angle_deg = 0.0;
  std::string time_source = "host";    // sensor | host
  std::string hour_source = "gprmc";   // sensor time: hour from gprmc (host as fallback) | host
  std::string clock_correction = "auto";  // sensor time through the clock mapper: auto | always | never
  std::string frame_id;                // default lidar_<name>
  int realtime_priority = 0;           // SCHED_FIFO priority of the driver thread; 0 = normal scheduling
  // Keep-last 2: a scan whose repair (lost fragment, slow ack) outlasts one scan period is still
  // in the writer's history when the next scan is written; depth 1 drops it.
  dds::QosSpec qos = lidar_qos();
  LidarMockConfig mock;
};

// Drive-by-wire: the bridge (`rig dbw bridge`) and, on the mock rig, the mock Paravan ECU and a
// simple command source, each its own process.
struct DbwConfig {
  bool enabled = false;
  std::string protocol;                 // mapping YAML (default: config/dbw/paravan_ref.yaml)
  std::string bus = "/tmp/rig_paravan.sock";  // unix seqpacket bus path (mock) ...
  std::string transport;                // ... or an explicit bridge transport (socketcan:can0); empty = unix:<bus>
  bool mock_ecu = false;
  int realtime_priority = 30;           // SCHED_FIFO for bridge, mock ECU and command source; 0 = normal
  std::vector<std::string> mock_faults;  // `rig mock paravan --fault` values
  struct CommandSource {
    bool enabled = false;
    double rate_hz = 50;
    double steer_rad = 0.05;
    double throttle = 0.2;
    double brake = 0.0;
    int gear = 4;
  } command_source;
};

struct RigConfig {
  std::string file;   // where it was loaded from
  std::string name = "rig";
  dds::DomainConfig dds;
  int diagnostics_period_ms = 1000;
  std::vector<LidarConfig> lidars;
  DbwConfig dbw;
};

// Loads and validates; throws ConfigError listing every problem (file:line:col: key: message).
RigConfig load_rig_config(const std::string& path);
// The decoder options a LIDAR's config asks for, its calibration and metadata files read; throws
// std::runtime_error when one cannot be read. The driver and `rig config check` build from this.
lidar::DecoderOptions decoder_options(const LidarConfig& c);
// Human-readable summary for `rig config check`.
std::string describe(const RigConfig& cfg);

}  // namespace sensor_rig::runtime
