#include "sensor_rig/camera/pixel_format.hpp"

#include <array>

namespace sensor_rig::camera {
namespace {

// PFNC codes: (mono/color flag << 24) | (bits << 16) | id, as GenICam PFNC and Aravis arvtypes.h.
constexpr std::uint32_t pfnc(std::uint32_t color, std::uint32_t bits, std::uint32_t id) {
  return (color << 24) | (bits << 16) | id;
}
constexpr std::uint32_t kMono = 0x01;
constexpr std::uint32_t kColor = 0x02;

constexpr std::array kFormats{
    PixelFormatInfo{PixelFormat::kMono8, "Mono8", pfnc(kMono, 8, 0x0001), fourcc('G', 'R', 'E', 'Y'), "GREY", "mono8", 8, false},
    PixelFormatInfo{PixelFormat::kMono16, "Mono16", pfnc(kMono, 16, 0x0007), fourcc('Y', '1', '6', ' '), "Y16", "mono16", 16, false},
    PixelFormatInfo{PixelFormat::kBayerRG8, "BayerRG8", pfnc(kMono, 8, 0x0009), fourcc('R', 'G', 'G', 'B'), "RGGB", "bayer_rggb8", 8, false},
    PixelFormatInfo{PixelFormat::kBayerGR8, "BayerGR8", pfnc(kMono, 8, 0x0008), fourcc('G', 'R', 'B', 'G'), "GRBG", "bayer_grbg8", 8, false},
    PixelFormatInfo{PixelFormat::kBayerGB8, "BayerGB8", pfnc(kMono, 8, 0x000a), fourcc('G', 'B', 'R', 'G'), "GBRG", "bayer_gbrg8", 8, false},
    PixelFormatInfo{PixelFormat::kBayerBG8, "BayerBG8", pfnc(kMono, 8, 0x000b), fourcc('B', 'A', '8', '1'), "BA81", "bayer_bggr8", 8, false},
    PixelFormatInfo{PixelFormat::kBayerRG16, "BayerRG16", pfnc(kMono, 16, 0x002f), 0, nullptr, "bayer_rggb16", 16, false},
    PixelFormatInfo{PixelFormat::kRgb8, "RGB8", pfnc(kColor, 24, 0x0014), fourcc('R', 'G', 'B', '3'), "RGB3", "rgb8", 24, false},
    PixelFormatInfo{PixelFormat::kBgr8, "BGR8", pfnc(kColor, 24, 0x0015), fourcc('B', 'G', 'R', '3'), "BGR3", "bgr8", 24, false},
    PixelFormatInfo{PixelFormat::kYuv422Yuyv, "YUV422_8", pfnc(kColor, 16, 0x0032), fourcc('Y', 'U', 'Y', 'V'), "YUYV", "yuv422_yuy2", 16, false},
    PixelFormatInfo{PixelFormat::kMjpeg, nullptr, 0, fourcc('M', 'J', 'P', 'G'), "MJPG", nullptr, 0, true},
};
static_assert(kFormats.size() == static_cast<std::size_t>(PixelFormat::kMjpeg) + 1);

bool eq(const char* a, std::string_view b) { return a != nullptr && std::string_view(a) == b; }

}  // namespace

std::string fourcc_string(std::uint32_t code) {
  std::string s(4, ' ');
  for (std::size_t i = 0; i < 4; ++i) s[i] = static_cast<char>((code >> (8 * i)) & 0xff);
  return s;
}

std::span<const PixelFormatInfo> pixel_formats() noexcept { return kFormats; }

const PixelFormatInfo& info(PixelFormat f) noexcept { return kFormats[static_cast<std::size_t>(f)]; }

std::optional<PixelFormat> parse_pixel_format(std::string_view name) noexcept {
  for (const auto& f : kFormats)
    if (eq(f.genicam, name) || eq(f.v4l2_name, name) || eq(f.ros_encoding, name)) return f.format;
  return std::nullopt;
}

std::optional<PixelFormat> from_genicam_code(std::uint32_t code) noexcept {
  for (const auto& f : kFormats)
    if (f.genicam_code != 0 && f.genicam_code == code) return f.format;
  return std::nullopt;
}

std::optional<PixelFormat> from_v4l2(std::uint32_t code) noexcept {
  for (const auto& f : kFormats)
    if (f.v4l2 != 0 && f.v4l2 == code) return f.format;
  return std::nullopt;
}

bool backend_supports(std::string_view backend, PixelFormat f) noexcept {
  const auto& i = info(f);
  if (i.compressed) return false;  // image_raw carries raw pixels; MJPG would need a decoder
  if (backend == "aravis") return i.genicam != nullptr;
  if (backend == "v4l2") return i.v4l2 != 0;
  return false;
}

std::string pixel_format_names(std::string_view backend) {
  std::string out;
  for (const auto& f : kFormats) {
    if (!backend_supports(backend, f.format)) continue;
    if (!out.empty()) out += ", ";
    out += backend == "aravis" ? f.genicam : f.v4l2_name;
  }
  return out;
}

}  // namespace sensor_rig::camera
