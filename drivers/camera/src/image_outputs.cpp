#include "image_outputs.hpp"

#include <mutex>
#include <vector>

#include "sensor_rig/camera/jpeg.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/camera/frame_worker.hpp"

namespace sensor_rig::drivers {

struct ImageOutputs::Impl {
  CameraConfig cfg;
  std::string color_topic_name;
  std::string compressed_topic_name;
  dds::StampsWriter& stamps;
  std::optional<dds::Topic<msg::Image>> color_topic;
  std::optional<dds::Writer<msg::Image>> color_writer;
  std::optional<dds::Topic<msg::CompressedImage>> jpeg_topic;
  std::optional<dds::Writer<msg::CompressedImage>> jpeg_writer;
  std::vector<std::uint8_t> color;  // the debayered frame, allocated once
  camera::JpegEncoder encoder;
  std::string jpeg_format;
  camera::ColorOrder order;
  FrameWorker worker;

  mutable std::mutex mutex;  // counters below: written by the worker, read by status
  std::uint64_t color_frames = 0;
  std::uint64_t jpeg_frames = 0;
  std::uint64_t errors = 0;
  std::uint64_t jpeg_bytes_last = 0;
  double debayer_ms_last = 0.0;
  double jpeg_ms_last = 0.0;
  std::string last_error;

  Impl(const CameraConfig& c, const dds::Participant& p, dds::StampsWriter& st)
      : cfg(c),
        color_topic_name("/sensors/camera/" + c.name + "/image_color"),
        compressed_topic_name("/sensors/camera/" + c.name + "/image_raw/compressed"),
        stamps(st),
        encoder(c.outputs.jpeg_quality),
        // JPEG of a Bayer camera is made from the colour image; without image_color, in bgr8 (as ROS).
        order(c.outputs.color ? c.outputs.color_order : camera::ColorOrder::kBgr),
        worker("camw:" + c.name, camera::frame_bytes(c.source.format, c.source.width, c.source.height), c.outputs.queue_depth,
               [this](const WorkerJob& j) { process(j); }) {
    if (cfg.outputs.color) {
      color_topic.emplace(p, color_topic_name, cfg.qos);
      color_writer.emplace(p, *color_topic, cfg.qos);
    }
    if (cfg.outputs.compressed) {
      jpeg_topic.emplace(p, compressed_topic_name, cfg.qos);
      jpeg_writer.emplace(p, *jpeg_topic, cfg.qos);
    }
    const bool bayer = camera::is_bayer8(cfg.source.format);
    if (bayer) color.resize(static_cast<std::size_t>(cfg.source.width) * cfg.source.height * 3);
    const char* raw_enc = camera::info(cfg.source.format).ros_encoding;
    const char* jpeg_enc = bayer ? camera::ros_encoding(order) : raw_enc;
    jpeg_format = std::string(raw_enc != nullptr ? raw_enc : "?") + "; jpeg compressed " + (jpeg_enc != nullptr ? jpeg_enc : "?");
  }

  void fail(const std::string& why) {
    std::lock_guard lock(mutex);
    ++errors;
    last_error = why;
  }

  void process(const WorkerJob& j) {
    const Nanos start = vehicle_now_ns();
    const auto& m = j.meta;
    const msg::Time stamp = msg::to_time(j.stamp_ns);
    std::span<const std::uint8_t> colour_bytes;
    camera::PixelFormat colour_format = m.format;
    std::uint32_t colour_step = m.step;
    if (camera::is_bayer8(m.format)) {
      const auto t0 = monotonic_now_ns();
      const auto rc = camera::debayer({j.data, m.width, m.height, m.step, m.format}, order, color);
      if (rc != camera::DebayerStatus::kOk) return fail(std::string("debayer: ") + camera::to_string(rc));
      const double ms = static_cast<double>(monotonic_now_ns() - t0) * 1e-6;
      colour_bytes = {color.data(), static_cast<std::size_t>(m.width) * m.height * 3};
      colour_format = order == camera::ColorOrder::kRgb ? camera::PixelFormat::kRgb8 : camera::PixelFormat::kBgr8;
      colour_step = m.width * 3;
      std::lock_guard lock(mutex);
      debayer_ms_last = ms;
    } else {
      colour_bytes = j.data;
    }
    if (color_writer) {
      msg::Image img{};
      img.header.stamp = stamp;
      img.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
      img.height = m.height;
      img.width = m.width;
      img.encoding = const_cast<char*>(camera::ros_encoding(order));
      img.step = colour_step;
      img.data._buffer = const_cast<std::uint8_t*>(colour_bytes.data());
      img.data._length = img.data._maximum = static_cast<std::uint32_t>(colour_bytes.size());
      img.data._release = false;
      const Nanos publish = vehicle_now_ns();
      const auto rc = color_writer->write(img, publish);
      const Nanos written = vehicle_now_ns();
      dds::SampleStamps s{j.stamp_ns, m.first_rx_ns, m.complete_ns, start, publish, written, m.packets, 0, img.data._length};
      stamps.write(color_topic_name, stamp, img.header.frame_id, m.seq, s);
      if (!rc.ok()) return fail("image_color write: " + rc.message());
      std::lock_guard lock(mutex);
      ++color_frames;
    }
    if (jpeg_writer) {
      const auto t0 = monotonic_now_ns();
      const auto rc = encoder.encode({colour_bytes, m.width, m.height, colour_step, colour_format});
      if (rc != camera::JpegStatus::kOk) return fail("jpeg: " + encoder.last_error());
      const double ms = static_cast<double>(monotonic_now_ns() - t0) * 1e-6;
      msg::CompressedImage ci{};
      ci.header.stamp = stamp;
      ci.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
      ci.format = const_cast<char*>(jpeg_format.c_str());
      const auto bytes = encoder.jpeg();
      ci.data._buffer = const_cast<std::uint8_t*>(bytes.data());
      ci.data._length = ci.data._maximum = static_cast<std::uint32_t>(bytes.size());
      ci.data._release = false;
      const Nanos publish = vehicle_now_ns();
      const auto wrc = jpeg_writer->write(ci, publish);
      const Nanos written = vehicle_now_ns();
      // Announced on /rig/stamps as image_raw and image_color are (seq: the frame's, so a frame the
      // worker never compressed is a gap), also when the write failed: `rig record` and `rig monitor`
      // then count a JPEG that never reached them. ready: the worker took the frame (debayer and
      // encoding are the process stage).
      dds::SampleStamps s{j.stamp_ns, m.first_rx_ns, m.complete_ns, start, publish, written, m.packets, 0, ci.data._length};
      stamps.write(compressed_topic_name, stamp, ci.header.frame_id, m.seq, s);
      if (!wrc.ok()) return fail("compressed write: " + wrc.message());
      std::lock_guard lock(mutex);
      ++jpeg_frames;
      jpeg_bytes_last = bytes.size();
      jpeg_ms_last = ms;
    }
  }
};

ImageOutputs::ImageOutputs(const CameraConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps)
    : impl_(std::make_unique<Impl>(cfg, participant, stamps)) {}

ImageOutputs::~ImageOutputs() { stop(); }

void ImageOutputs::start() {
  impl_->worker.start();
  std::string what;
  if (impl_->color_writer) what += " " + impl_->color_topic_name;
  if (impl_->jpeg_writer) what += " " + impl_->compressed_topic_name;
  log::info("camera", impl_->cfg.name + ": worker ->" + what);
}

void ImageOutputs::stop() { impl_->worker.stop(); }

void ImageOutputs::offer(const camera::FrameMeta& meta, Nanos stamp_ns, std::span<const std::uint8_t> data) {
  (void)impl_->worker.offer(meta, stamp_ns, data);
}

void ImageOutputs::add_status(dds::DriverStatus& s) const {
  const auto w = impl_->worker.counters();
  std::lock_guard lock(impl_->mutex);
  s.add_number("worker_queue_depth", static_cast<std::uint64_t>(impl_->worker.depth()));
  s.add_number("worker_offered", w.offered);
  s.add_number("worker_processed", w.processed);
  s.add_number("worker_dropped", w.dropped);
  s.add_number("worker_oversize", w.oversize);
  s.add("worker_last_ms", std::to_string(w.last_process_ms));
  s.add("worker_max_ms", std::to_string(w.max_process_ms));
  s.add_number("worker_errors", impl_->errors);
  if (impl_->color_writer) {
    s.add_number("color_frames", impl_->color_frames);
    s.add("debayer_ms", std::to_string(impl_->debayer_ms_last));
  }
  if (impl_->jpeg_writer) {
    s.add_number("compressed_frames", impl_->jpeg_frames);
    s.add_number("compressed_bytes", impl_->jpeg_bytes_last);
    s.add("jpeg_ms", std::to_string(impl_->jpeg_ms_last));
  }
  if (!impl_->last_error.empty()) s.add("worker_last_error", impl_->last_error);
}

}  // namespace sensor_rig::drivers
