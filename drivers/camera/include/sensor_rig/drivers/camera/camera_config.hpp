#pragma once
// A camera node's configuration (the `cameras:` items of a rig config) as a plain struct with
// defaults, and its parser: unknown keys, formats the backend cannot do, bad values and a
// calibration of another size are reported at file:line:col, all at once.
#include <string>

#include "sensor_rig/camera/calibration.hpp"
#include "sensor_rig/camera/debayer.hpp"
#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/qos.hpp"

namespace sensor_rig::drivers {

struct CameraMockConfig {
  // none: a real device | gige: arv-fake-gv-camera-0.8 on `device` (a loopback address) |
  // aravis-inprocess: an in-process Aravis fake | v4l2-fake: the fake V4L2 device
  enum class Kind { kNone, kGige, kAravisInProcess, kV4l2Fake } kind = Kind::kNone;
  int lost_packets_per_thousand = 0;  // gige: the fake's -r (GVSP packet loss)
};
const char* to_string(CameraMockConfig::Kind k) noexcept;

// Keep-last 3: Cyclone keeps an unacknowledged sample only while it is in the keep-last history,
// so a frame whose repair to a reader (fragments dropped by a full socket buffer on a loaded host)
// is still running when the next frame is written was lost at depth 1 — never delivered, counted
// nowhere (issue 10: 2-3 frames a minute of seven 1920x1200 cameras at load 9-15; depth 3: none).
// Three frames give a repair 300 ms; more would only hold more memory (an image is 2-7 MB per
// slot). A slow subscriber must not make the capture thread block (max_blocking_ms) for long.
// Reliable so default ROS subscribers match.
inline dds::QosSpec camera_qos() {
  dds::QosSpec q;
  q.depth = 3;
  q.max_blocking_ms = 50;
  return q;
}

// Optional outputs beside image_raw, made by one worker thread per camera off the capture thread:
// .../image_color (Bayer 8-bit debayered to bgr8/rgb8) and .../image_raw/compressed (JPEG).
struct CameraOutputsConfig {
  bool color = false;                                  // image_color
  camera::ColorOrder color_order = camera::ColorOrder::kBgr;
  bool compressed = false;                             // image_raw/compressed
  int jpeg_quality = 90;                               // 1..100
  int queue_depth = 1;                                 // 1..2 frames waiting; more: the oldest is dropped
  [[nodiscard]] bool any() const noexcept { return color || compressed; }
};

// `trigger: {lidar: NAME, azimuth_deg: A, latency_us: L}`: software-triggered when that LIDAR's
// sweep crosses azimuth A (its frame, REP 103: 0 forward, 90 left), fired L before the predicted
// crossing so that the exposure starts on it (L: the camera's trigger-to-exposure latency).
struct LidarTriggerConfig {
  std::string lidar;              // empty: not LIDAR-triggered
  double azimuth_deg = 0.0;       // [0, 360)
  double latency_us = 0.0;        // trigger command -> exposure start
  [[nodiscard]] bool enabled() const noexcept { return !lidar.empty(); }
};

struct CameraConfig {
  std::string name;                 // /sensors/camera/<name>/image_raw, frame camera_<name>
  camera::SourceConfig source;      // backend, device, format, size, rate, exposure, gain, trigger
  std::string calibration;          // ROS camera_calibration YAML; "" = uncalibrated
  camera::CameraInfo info;          // loaded from `calibration` (or uncalibrated of the size)
  std::string frame_id;             // default camera_<name>
  std::string trigger_group;        // software trigger: cameras of a group share one tick
  LidarTriggerConfig lidar_trigger; // software trigger at a LIDAR's sweep crossing (rig checks the name);
                                    // with a group: the same for every member, one trigger fires them all
  int realtime_priority = 0;
  int watchdog_ms = 0;              // no frame for this long: reported and reopened; 0 = auto
  dds::QosSpec qos = camera_qos();
  CameraMockConfig mock;
  CameraOutputsConfig outputs;

  [[nodiscard]] int watchdog() const noexcept;  // the effective watchdog (< 1 s)
};

CameraConfig parse_camera_config(const config::Node& n);

}  // namespace sensor_rig::drivers
