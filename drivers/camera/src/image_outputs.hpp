#pragma once
// A camera's optional outputs, made on its FrameWorker thread (never the capture thread):
// .../image_color (debayer, bgr8/rgb8, with source stamps) and .../image_raw/compressed
// (sensor_msgs/CompressedImage, JPEG; format as compressed_image_transport writes it).
#include <memory>
#include <span>
#include <string>

#include "sensor_rig/camera/frame.hpp"
#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/camera/camera_config.hpp"

namespace sensor_rig::drivers {

class ImageOutputs {
 public:
  ImageOutputs(const CameraConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps);
  ~ImageOutputs();
  ImageOutputs(const ImageOutputs&) = delete;
  ImageOutputs& operator=(const ImageOutputs&) = delete;

  void start();
  void stop();
  // Capture thread: copy the frame into the worker's queue (drops the oldest when full).
  void offer(const camera::FrameMeta& meta, Nanos stamp_ns, std::span<const std::uint8_t> data);
  // Counters for /diagnostics.
  void add_status(dds::DriverStatus& s) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::drivers
