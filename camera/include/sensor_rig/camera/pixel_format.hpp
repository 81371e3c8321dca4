#pragma once
// Pixel formats as data: one table row per format with its GenICam PixelFormat name, its V4L2
// fourcc, its ROS sensor_msgs/Image encoding and its size. Pure: no I/O.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace sensor_rig::camera {

enum class PixelFormat : std::uint8_t {
  kMono8 = 0,
  kMono16,
  kBayerRG8,
  kBayerGR8,
  kBayerGB8,
  kBayerBG8,
  kBayerRG16,
  kRgb8,
  kBgr8,
  kYuv422Yuyv,
  kMjpeg,  // compressed: V4L2 MJPG; not publishable as image_raw
};

constexpr std::uint32_t fourcc(char a, char b, char c, char d) noexcept {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(a)) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(b)) << 8) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(c)) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(d)) << 24);
}
std::string fourcc_string(std::uint32_t code);

struct PixelFormatInfo {
  PixelFormat format;
  const char* genicam;       // GenICam SFNC PixelFormat name ("BayerRG8"); nullptr: none
  std::uint32_t genicam_code;  // PFNC value (as Aravis' ARV_PIXEL_FORMAT_*); 0: none
  std::uint32_t v4l2;        // V4L2 fourcc; 0: none
  const char* v4l2_name;     // the fourcc as text ("YUYV")
  const char* ros_encoding;  // sensor_msgs/image_encodings ("bayer_rggb8"); nullptr: compressed
  std::uint32_t bits_per_pixel;
  bool compressed;
};

std::span<const PixelFormatInfo> pixel_formats() noexcept;
const PixelFormatInfo& info(PixelFormat f) noexcept;

// By GenICam name, fourcc text (YUYV, GREY, RGB3, BA81, MJPG...) or ROS encoding; case-sensitive.
std::optional<PixelFormat> parse_pixel_format(std::string_view name) noexcept;
std::optional<PixelFormat> from_genicam_code(std::uint32_t pfnc) noexcept;
std::optional<PixelFormat> from_v4l2(std::uint32_t fourcc) noexcept;
// All names parse_pixel_format accepts for the given backend ("aravis" | "v4l2"), comma separated.
std::string pixel_format_names(std::string_view backend);
bool backend_supports(std::string_view backend, PixelFormat f) noexcept;

inline std::uint32_t bytes_per_pixel(PixelFormat f) noexcept { return info(f).bits_per_pixel / 8; }
// Bytes per row (ROS Image.step), no padding.
inline std::uint32_t row_step(PixelFormat f, std::uint32_t width) noexcept { return bytes_per_pixel(f) * width; }
inline std::size_t frame_bytes(PixelFormat f, std::uint32_t width, std::uint32_t height) noexcept {
  return static_cast<std::size_t>(row_step(f, width)) * height;
}
inline bool is_bayer(PixelFormat f) noexcept {
  return f == PixelFormat::kBayerRG8 || f == PixelFormat::kBayerGR8 || f == PixelFormat::kBayerGB8 ||
         f == PixelFormat::kBayerBG8 || f == PixelFormat::kBayerRG16;
}

}  // namespace sensor_rig::camera
