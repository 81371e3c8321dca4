#pragma once
// One camera: frame source (camera/) -> exposure start in vehicle time (FrameClock, timesync) ->
// sensor_msgs/Image on rt/sensors/camera/<name>/image_raw (the frame's buffer is Image.data) +
// CameraInfo on .../camera_info + SourceStamps on rt/rig/stamps. Its own thread; a frame
// watchdog (< 1 s) and Aravis control-lost report a dead camera and reopen it by themselves.
#include <memory>
#include <string>

#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/camera/trigger_group.hpp"

namespace sensor_rig::drivers {

// The source a config asks for (real device or the mock kind's fake); throws camera::CameraError.
std::unique_ptr<camera::FrameSource> make_camera_source(const CameraConfig& cfg);

class CameraDriver {
 public:
  CameraDriver(const CameraConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps,
               TriggerSource* trigger = nullptr);
  // With a given source (tests).
  CameraDriver(const CameraConfig& cfg, std::unique_ptr<camera::FrameSource> source, const dds::Participant& participant,
               dds::StampsWriter& stamps, TriggerSource* trigger = nullptr);
  ~CameraDriver();
  CameraDriver(const CameraDriver&) = delete;
  CameraDriver& operator=(const CameraDriver&) = delete;

  void start();
  void stop();
  // Asks the capture thread to end without waiting (stop() joins it): a rig stops all its cameras
  // at once, so a camera in a reopen attempt costs its own time, not the sum over cameras.
  void request_stop() noexcept;
  [[nodiscard]] dds::DriverStatus status() const;
  [[nodiscard]] std::string topic() const;
  [[nodiscard]] camera::FrameSource& source();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::drivers
