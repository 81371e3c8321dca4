// JPEG: what the encoder writes decodes back (tjDecompress2) to the image within tolerance, in
// the right channel order; unsupported formats and short inputs are values.
#include <gtest/gtest.h>
#include <turbojpeg.h>

#include <cmath>
#include <cstdlib>
#include <vector>

#include "sensor_rig/camera/jpeg.hpp"

namespace sensor_rig::camera {
namespace {

struct Decoded {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;
};

Decoded decode(std::span<const std::uint8_t> jpeg, int pixel_format) {
  tjhandle h = tjInitDecompress();
  Decoded d;
  int samp = 0, cs = 0;
  if (tjDecompressHeader3(h, jpeg.data(), jpeg.size(), &d.width, &d.height, &samp, &cs) != 0) {
    tjDestroy(h);
    ADD_FAILURE() << "not a JPEG";
    return {};
  }
  d.pixels.resize(static_cast<std::size_t>(d.width) * d.height * tjPixelSize[pixel_format]);
  EXPECT_EQ(tjDecompress2(h, jpeg.data(), jpeg.size(), d.pixels.data(), d.width, 0, d.height, pixel_format, 0), 0)
      << tjGetErrorStr2(h);
  tjDestroy(h);
  return d;
}

// Smooth, distinct per channel: R rises with x, G with y, B is constant.
std::vector<std::uint8_t> scene_bgr(std::uint32_t w, std::uint32_t h, std::uint32_t step) {
  std::vector<std::uint8_t> img(static_cast<std::size_t>(step) * h, 0);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      std::uint8_t* p = &img[y * step + 3 * x];
      p[0] = 40;
      p[1] = static_cast<std::uint8_t>(255 * y / (h - 1));
      p[2] = static_cast<std::uint8_t>(255 * x / (w - 1));
    }
  return img;
}

TEST(Jpeg, Bgr8DecodesBackWithinTolerance) {
  const std::uint32_t w = 160, h = 120, step = w * 3 + 8;  // padded rows
  const auto img = scene_bgr(w, h, step);
  JpegEncoder enc(90);
  ASSERT_EQ(enc.encode({img, w, h, step, PixelFormat::kBgr8}), JpegStatus::kOk) << enc.last_error();
  ASSERT_GT(enc.jpeg().size(), 100u);
  EXPECT_LT(enc.jpeg().size(), static_cast<std::size_t>(w) * h * 3 / 4);
  const auto d = decode(enc.jpeg(), TJPF_BGR);
  ASSERT_EQ(d.width, static_cast<int>(w));
  ASSERT_EQ(d.height, static_cast<int>(h));
  double sum = 0;
  int worst = 0;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w * 3; ++x) {
      const int e = std::abs(int{d.pixels[y * w * 3 + x]} - int{img[y * step + x]});
      sum += e;
      worst = std::max(worst, e);
    }
  EXPECT_LT(sum / (w * h * 3), 2.5);
  EXPECT_LT(worst, 24);
}

TEST(Jpeg, RgbOrderIsKept) {
  // The same bytes declared rgb8 must decode as RGB with the first byte red: read back as BGR,
  // byte 0 would be blue (40), not the x ramp.
  const std::uint32_t w = 64, h = 32;
  const auto img = scene_bgr(w, h, w * 3);  // bytes: 40, y, x
  JpegEncoder enc(95);
  ASSERT_EQ(enc.encode({img, w, h, w * 3, PixelFormat::kRgb8}), JpegStatus::kOk);
  const auto d = decode(enc.jpeg(), TJPF_RGB);
  ASSERT_EQ(d.pixels.size(), img.size());
  const std::size_t right = (16 * w + (w - 2)) * 3;
  EXPECT_NEAR(d.pixels[right + 0], 40, 8);
  EXPECT_NEAR(d.pixels[right + 2], img[right + 2], 8);
}

TEST(Jpeg, Mono8IsGreyscale) {
  const std::uint32_t w = 64, h = 48;
  std::vector<std::uint8_t> img(w * h);
  for (std::uint32_t i = 0; i < img.size(); ++i) img[i] = static_cast<std::uint8_t>((i % w) * 4);
  JpegEncoder enc(90);
  ASSERT_EQ(enc.encode({img, w, h, w, PixelFormat::kMono8}), JpegStatus::kOk);
  const auto d = decode(enc.jpeg(), TJPF_GRAY);
  ASSERT_EQ(d.pixels.size(), img.size());
  double sum = 0;
  for (std::size_t i = 0; i < img.size(); ++i) sum += std::abs(int{d.pixels[i]} - int{img[i]});
  EXPECT_LT(sum / static_cast<double>(img.size()), 2.0);
}

TEST(Jpeg, UnsupportedAndShortInputsAreValues) {
  std::vector<std::uint8_t> img(64 * 48 * 3);
  JpegEncoder enc;
  EXPECT_EQ(enc.encode({img, 64, 48, 64, PixelFormat::kBayerRG8}), JpegStatus::kUnsupportedFormat);
  EXPECT_EQ(enc.encode({img, 64, 49, 64 * 3, PixelFormat::kBgr8}), JpegStatus::kShortInput);
  EXPECT_EQ(enc.encode({img, 64, 48, 64 * 2, PixelFormat::kBgr8}), JpegStatus::kShortInput);
  EXPECT_FALSE(JpegEncoder::supports(PixelFormat::kYuv422Yuyv));
  EXPECT_TRUE(JpegEncoder::supports(PixelFormat::kBgr8));
}

}  // namespace
}  // namespace sensor_rig::camera
