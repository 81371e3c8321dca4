#pragma once
// JPEG compression of a frame with libturbojpeg, for sensor_msgs/CompressedImage. No DDS, no I/O.
// One encoder per thread (a turbojpeg handle is not thread-safe); its output buffer is allocated
// once for the largest image of its size (tjBufSize) and reused: no allocation per frame.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/camera/pixel_format.hpp"

namespace sensor_rig::camera {

enum class JpegStatus : std::uint8_t {
  kOk = 0,
  kUnsupportedFormat,  // only mono8, rgb8, bgr8 (debayer Bayer first)
  kShortInput,
  kEncoderError,
};

struct JpegImage {
  std::span<const std::uint8_t> data;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t step = 0;
  PixelFormat format = PixelFormat::kBgr8;
};

class JpegEncoder {
 public:
  explicit JpegEncoder(int quality = 90);  // 1..100; throws std::runtime_error when turbojpeg fails
  ~JpegEncoder();
  JpegEncoder(const JpegEncoder&) = delete;
  JpegEncoder& operator=(const JpegEncoder&) = delete;

  static bool supports(PixelFormat f) noexcept;
  // On kOk, `jpeg()` holds the compressed bytes until the next call.
  JpegStatus encode(const JpegImage& img);
  [[nodiscard]] std::span<const std::uint8_t> jpeg() const noexcept { return {buffer_.data(), size_}; }
  [[nodiscard]] const std::string& last_error() const noexcept { return error_; }
  [[nodiscard]] int quality() const noexcept { return quality_; }

 private:
  void* handle_ = nullptr;
  int quality_;
  std::vector<std::uint8_t> buffer_;
  std::size_t size_ = 0;
  std::string error_;
};

}  // namespace sensor_rig::camera
