#pragma once
// Bayer 8-bit -> 3-channel 8-bit colour (rgb8 / bgr8). Pure: no I/O, no allocation.
//
// The one algorithm, bilinear with reflect-101 borders (index -1 reads 1, `w` reads w-2, which keeps
// the Bayer phase), integer rounding half up: every missing channel of a pixel is the mean of the
// same-colour sites in its 3x3 neighbourhood. `debayer` is the row-pointer version written for speed;
// `debayer_reference` computes that definition per pixel and per channel, for tests and benchmarks.
#include <cstdint>
#include <span>

#include "sensor_rig/camera/pixel_format.hpp"

namespace sensor_rig::camera {

enum class ColorOrder : std::uint8_t { kRgb = 0, kBgr };
const char* ros_encoding(ColorOrder o) noexcept;  // "rgb8" / "bgr8"

struct ImageIn {
  std::span<const std::uint8_t> data;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t step = 0;  // bytes per row, >= width
  PixelFormat format = PixelFormat::kBayerRG8;
};

enum class DebayerStatus : std::uint8_t {
  kOk = 0,
  kNotBayer8,      // the format is not BayerRG8/GR8/GB8/BG8
  kTooSmall,       // width or height < 2
  kShortInput,     // data shorter than step * height, or step < width
  kShortOutput,    // out shorter than width * height * 3
};
const char* to_string(DebayerStatus s) noexcept;

bool is_bayer8(PixelFormat f) noexcept;

// Writes width * height * 3 bytes, rows packed (step = 3 * width).
DebayerStatus debayer(const ImageIn& in, ColorOrder order, std::span<std::uint8_t> out) noexcept;
DebayerStatus debayer_reference(const ImageIn& in, ColorOrder order, std::span<std::uint8_t> out) noexcept;

}  // namespace sensor_rig::camera
