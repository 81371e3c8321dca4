#include "sensor_rig/camera/jpeg.hpp"

#include <turbojpeg.h>

#include <algorithm>
#include <stdexcept>

namespace sensor_rig::camera {

JpegEncoder::JpegEncoder(int quality) : quality_(std::clamp(quality, 1, 100)) {
  handle_ = tjInitCompress();
  if (handle_ == nullptr) throw std::runtime_error(std::string("turbojpeg: tjInitCompress: ") + tjGetErrorStr2(nullptr));
}

JpegEncoder::~JpegEncoder() {
  if (handle_ != nullptr) tjDestroy(handle_);
}

bool JpegEncoder::supports(PixelFormat f) noexcept {
  return f == PixelFormat::kMono8 || f == PixelFormat::kRgb8 || f == PixelFormat::kBgr8;
}

JpegStatus JpegEncoder::encode(const JpegImage& img) {
  int pf = TJPF_GRAY;
  int samp = TJSAMP_GRAY;
  switch (img.format) {
    case PixelFormat::kMono8: break;
    case PixelFormat::kRgb8: pf = TJPF_RGB; samp = TJSAMP_420; break;
    case PixelFormat::kBgr8: pf = TJPF_BGR; samp = TJSAMP_420; break;
    default: error_ = "unsupported pixel format"; return JpegStatus::kUnsupportedFormat;
  }
  const std::size_t row = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(tjPixelSize[pf]);
  if (img.width == 0 || img.height == 0 || img.step < row || img.data.size() < static_cast<std::size_t>(img.step) * img.height) {
    error_ = "input shorter than step x height";
    return JpegStatus::kShortInput;
  }
  const unsigned long bound = tjBufSize(static_cast<int>(img.width), static_cast<int>(img.height), samp);
  if (buffer_.size() < bound) buffer_.resize(bound);  // once per image size
  unsigned char* dst = buffer_.data();
  unsigned long size = bound;
  const int rc = tjCompress2(handle_, img.data.data(), static_cast<int>(img.width), static_cast<int>(img.step),
                             static_cast<int>(img.height), pf, &dst, &size, samp, quality_,
                             TJFLAG_NOREALLOC | TJFLAG_FASTDCT);
  if (rc != 0) {
    error_ = tjGetErrorStr2(handle_);
    size_ = 0;
    return JpegStatus::kEncoderError;
  }
  size_ = size;
  return JpegStatus::kOk;
}

}  // namespace sensor_rig::camera
