#pragma once
// A LIDAR node's configuration (the `lidars:` items of a rig config) as a plain struct with
// defaults, and its parser: unknown keys, wrong types and bad values are reported at file:line.
#include <cstdint>
#include <optional>
#include <string>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/drivers/lidar/extrinsics.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/timesync/stamper.hpp"

namespace sensor_rig::drivers {

// How the LIDAR's mock (started by `rig up` beside the driver) produces packets.
struct LidarMockConfig {
  enum class Kind { kNone, kSynthetic, kReplay, kMcap } kind = Kind::kNone;
  std::string pcap;          // replay: capture file (falls back to synthetic when absent and optional)
  // mcap: a recording's raw channel of this LIDAR (`rig record --raw`), sent at its recorded
  // receive times through the real driver (docs/recording.md "Replaying raw channels").
  std::string file;
  std::string topic;         // mcap: default /sensors/lidar/<name>/packets
  double delay_s = 1.0;      // mcap: the first packet this long after the start (as rig play --delay)
  double rate = 1.0;         // replay / mcap speed factor
  bool loop = true;          // replay / mcap: from the start again at the end (mcap: default false)
  int rpm = 600;             // synthetic: rotation speed
  // synthetic: phase lock, the rotor angle at every whole second (lidar/mock/phase_lock.hpp); LIDARs
  // locked alike complete their scans together. nullopt: free running, from whenever it starts.
  std::optional<double> phase_deg;
  double drop_rate = 0.0;    // fault injection, passed to `rig lidar replay`
  double corrupt_rate = 0.0;
};

// `record:` the raw packets as received (both ports) into rotating nanosecond pcap files
// <directory>/<name>_<seq>_<UTC>.pcap (lidar/pcap_recorder.hpp). Errors never stop the driver.
struct LidarRecordConfig {
  std::string directory;               // empty = no recording; relative to the config file
  double max_file_mb = 256;            // rotate before a file passes this size (MiB)
  double max_file_s = 60;              // rotate when a file spans this long; 0 = size only
  int max_files = 10;                  // keep at most this many files of this LIDAR (oldest deleted)
  // Packets waiting for the writer thread (MiB): how long a disk may stall before packets are
  // dropped from the recording (counted; capture goes on): 16 MiB is ~7 s of a VLP-32C, ~0.5 s of
  // an OS-1-128 at 1024x20.
  double queue_mb = 16;
};

// Where the data port's datagrams are read: a UDP socket (the kernel's IP stack reassembles and
// queues), or an AF_PACKET TPACKET_V3 ring on one interface (lidar/ring_source.hpp: kernel-filtered,
// block-batched, reassembled here, ring drops counted). With packet the ring also takes the second port.
enum class LidarSource { kUdp, kPacket };

inline dds::QosSpec lidar_qos() {
  dds::QosSpec q;
  q.depth = 2;
  return q;
}

struct LidarConfig {
  std::string name;                    // topics /sensors/lidar/<name>/points, .../imu, .../fix
  std::string model;                   // a model of the decoder registry (lidar/scan_decoder.hpp)
  std::string host = "127.0.0.1";      // bind address
  int port = 2368;                     // data port
  // The sensor's second port, 0 = none: Velodyne position packets (key position_port, 8308:
  // GPRMC/PPS -> time and /sensors/lidar/<name>/fix), Ouster IMU packets (key imu_port, 7503 ->
  // /sensors/lidar/<name>/imu). Its mock sends there too (`rig lidar replay --position-port`).
  int position_port = 0;
  int receive_buffer_bytes = 8 << 20;
  LidarSource source = LidarSource::kUdp;  // source: udp | packet
  std::string interface;               // packet: the interface the sensor is on (required)
  std::string sensor_address;          // packet: the sensor's IPv4 address; empty = any sender
  // packet: a ring block not yet full is handed over after this long (the delivery delay at low
  // rates; shorter costs CPU and shortens the stall the 128-block ring absorbs: 128 x this).
  int ring_retire_ms = 4;
  std::string calibration;             // empty = model defaults
  std::string metadata;                // sensor metadata JSON (Ouster)
  lidar::ReturnSelection returns = lidar::ReturnSelection::kStrongest;
  double min_range_m = 0.4;
  double max_range_m = 200.0;
  double cut_angle_deg = 0.0;
  // fov: {start: DEG, end: DEG}: the sensor's own FOV setting (clockwise); equal = the whole turn.
  double fov_start_deg = 0.0;
  double fov_end_deg = 0.0;
  lidar::AzimuthInterpolation azimuth = lidar::AzimuthInterpolation::kPerLaser;  // Velodyne: per-laser | per-sequence
  // Velodyne / Hesai: the rotation speed the sensor is set to (its web page or API), 0 = not said.
  // It sizes what a scan can hold (the shared-memory pools): a scan at 300 rpm carries twice the
  // points of one at 600. Not said, a real sensor is sized for its slowest speed (kSlowestRpm);
  // a synthetic mock turns at this speed unless mock.rpm says otherwise.
  int rpm = 0;
  timesync::TimeSource time_source = timesync::TimeSource::kHost;    // sensor | host
  timesync::HourSource hour_source = timesync::HourSource::kGprmc;   // sensor time: gprmc (host as fallback) | host
  timesync::Correction clock_correction = timesync::Correction::kAuto;  // through the clock mapper: auto | always | never
  std::string frame_id;                // default lidar_<name>
  std::optional<Extrinsics> extrinsics;  // the frame in base_link; the fused cloud needs it
  int realtime_priority = 0;           // SCHED_FIFO priority of the driver thread; 0 = normal scheduling
  // Keep-last 2: a scan whose repair (lost fragment, slow ack) outlasts one scan period is still
  // in the writer's history when the next scan is written; depth 1 drops it.
  dds::QosSpec qos = lidar_qos();
  LidarMockConfig mock;
  LidarRecordConfig record;
};

// The slowest rotation a Velodyne or Hesai can be set to (VLP-16/32C, HDL-32E: 300-1200 rpm): what a
// real sensor whose `rpm` the config does not give is sized for.
inline constexpr int kSlowestRpm = 300;
// The rotation speed a LIDAR's scans are sized for: its synthetic mock's, else its config's `rpm`,
// else kSlowestRpm. (Ouster: its metadata's lidar_mode, not this.)
int sizing_rpm(const LidarConfig& c) noexcept;

// Parses one `lidars:` item; problems go to the node's problem list (reported all at once).
LidarConfig parse_lidar_config(const config::Node& n);
// The decoder options a LIDAR's config asks for, its calibration and metadata files read; throws
// std::runtime_error when one cannot be read. The driver and `rig config check` build from this.
lidar::DecoderOptions decoder_options(const LidarConfig& c);
// The options `rig up` starts a LIDAR's synthetic mock with (model, rpm, port; nominal otherwise):
// what the config check validates, the synthetic Ouster metadata and the RouDi pools follow from.
lidar::mock::SyntheticOptions synthetic_mock_options(const LidarConfig& c);

}  // namespace sensor_rig::drivers
