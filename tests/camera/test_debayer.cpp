// Debayer: known colour scenes through every Bayer pattern give the scene back; the fast version
// equals the per-pixel definition on random data (odd sizes, padded rows); bad inputs are values.
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <vector>

#include "sensor_rig/camera/debayer.hpp"

namespace sensor_rig::camera {
namespace {

struct Rgb {
  std::uint8_t r, g, b;
};

// Site colour [y&1][x&1] (0 R, 1 G, 2 B), written out per pattern name as a camera manual does.
std::array<std::array<int, 2>, 2> sites(PixelFormat f) {
  switch (f) {
    case PixelFormat::kBayerRG8: return {{{0, 1}, {1, 2}}};  // R G / G B
    case PixelFormat::kBayerBG8: return {{{2, 1}, {1, 0}}};  // B G / G R
    case PixelFormat::kBayerGR8: return {{{1, 0}, {2, 1}}};  // G R / B G
    case PixelFormat::kBayerGB8: return {{{1, 2}, {0, 1}}};  // G B / R G
    default: return {};
  }
}

// A scene sampled through the colour filter array.
template <class Scene>
std::vector<std::uint8_t> mosaic(PixelFormat f, std::uint32_t w, std::uint32_t h, std::uint32_t step, Scene scene) {
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(step) * h, 0xEE);
  const auto s = sites(f);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const Rgb c = scene(x, y);
      const int site = s[y & 1][x & 1];
      raw[static_cast<std::size_t>(y) * step + x] = site == 0 ? c.r : site == 1 ? c.g : c.b;
    }
  return raw;
}

constexpr std::array kBayer{PixelFormat::kBayerRG8, PixelFormat::kBayerBG8, PixelFormat::kBayerGR8, PixelFormat::kBayerGB8};

TEST(Debayer, UniformColourComesBackEverywhereForEveryPatternAndOrder) {
  const Rgb colour{200, 100, 30};
  for (const auto f : kBayer)
    for (const auto order : {ColorOrder::kRgb, ColorOrder::kBgr}) {
      const std::uint32_t w = 10, h = 6;
      const auto raw = mosaic(f, w, h, w, [&](auto, auto) { return colour; });
      std::vector<std::uint8_t> out(w * h * 3);
      ASSERT_EQ(debayer({raw, w, h, w, f}, order, out), DebayerStatus::kOk);
      const bool rgb = order == ColorOrder::kRgb;
      for (std::size_t i = 0; i < w * h; ++i) {
        SCOPED_TRACE(::testing::Message() << info(f).genicam << (rgb ? " rgb" : " bgr") << " pixel " << i);
        ASSERT_EQ(out[3 * i + (rgb ? 0 : 2)], colour.r);
        ASSERT_EQ(out[3 * i + 1], colour.g);
        ASSERT_EQ(out[3 * i + (rgb ? 2 : 0)], colour.b);
      }
    }
}

TEST(Debayer, ColourBarsKeepTheirColoursAwayFromEdges) {
  // Vertical bars 4 px wide: red, green, blue, white. Pixels whose 3x3 window is inside one bar
  // are exact.
  const std::array<Rgb, 4> bars{{{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}}};
  const std::uint32_t w = 16, h = 8;
  auto scene = [&](std::uint32_t x, std::uint32_t) { return bars[x / 4]; };
  for (const auto f : kBayer) {
    const auto raw = mosaic(f, w, h, w, scene);
    std::vector<std::uint8_t> out(w * h * 3);
    ASSERT_EQ(debayer({raw, w, h, w, f}, ColorOrder::kBgr, out), DebayerStatus::kOk);
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x) {
        if (x % 4 == 0 || x % 4 == 3) continue;  // next to a bar edge
        const Rgb c = bars[x / 4];
        const std::uint8_t* px = &out[(y * w + x) * 3];
        EXPECT_EQ(px[2], c.r) << info(f).genicam << " at " << x << "," << y;
        EXPECT_EQ(px[1], c.g) << info(f).genicam << " at " << x << "," << y;
        EXPECT_EQ(px[0], c.b) << info(f).genicam << " at " << x << "," << y;
      }
  }
}

TEST(Debayer, HandComputedNeighbourMeans) {
  // RGGB 4x4, raw values = 10 * index: at (1,1) (a B site) R is the mean of the four diagonals
  // (0,0)(2,0)(0,2)(2,2) = 0, 20, 80, 100 -> 50; G the mean of (1,0)(0,1)(2,1)(1,2) = 10, 40, 60, 90 -> 50.
  // At (1,0) (G on an R row): R = mean(0, 20) = 10, B = mean of (1,-1)->(1,1) and (1,1) = 50.
  std::vector<std::uint8_t> raw(16);
  for (std::size_t i = 0; i < raw.size(); ++i) raw[i] = static_cast<std::uint8_t>(10 * i);
  std::vector<std::uint8_t> out(16 * 3);
  ASSERT_EQ(debayer({raw, 4, 4, 4, PixelFormat::kBayerRG8}, ColorOrder::kRgb, out), DebayerStatus::kOk);
  const std::uint8_t* p11 = &out[(1 * 4 + 1) * 3];
  EXPECT_EQ(p11[0], 50);
  EXPECT_EQ(p11[1], 50);
  EXPECT_EQ(p11[2], 50);
  const std::uint8_t* p10 = &out[1 * 3];
  EXPECT_EQ(p10[0], 10);
  EXPECT_EQ(p10[1], 10);
  EXPECT_EQ(p10[2], 50);
  const std::uint8_t* p22 = &out[(2 * 4 + 2) * 3];  // an R site: R own 100, B diagonals 50,70,130,150 -> 100
  EXPECT_EQ(p22[0], 100);
  EXPECT_EQ(p22[2], 100);
}

TEST(Debayer, FastEqualsPerPixelReferenceOnRandomImages) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> byte(0, 255);
  const std::array<std::array<std::uint32_t, 3>, 6> sizes{{{2, 2, 2}, {3, 5, 3}, {16, 9, 16}, {17, 8, 24}, {64, 48, 64}, {33, 31, 40}}};
  for (const auto& [w, h, step] : sizes)
    for (const auto f : kBayer)
      for (const auto order : {ColorOrder::kRgb, ColorOrder::kBgr}) {
        std::vector<std::uint8_t> raw(static_cast<std::size_t>(step) * h);
        for (auto& b : raw) b = static_cast<std::uint8_t>(byte(rng));
        std::vector<std::uint8_t> fast(w * h * 3, 1), ref(w * h * 3, 2);
        ASSERT_EQ(debayer({raw, w, h, step, f}, order, fast), DebayerStatus::kOk);
        ASSERT_EQ(debayer_reference({raw, w, h, step, f}, order, ref), DebayerStatus::kOk);
        for (std::size_t i = 0; i < fast.size(); ++i)
          ASSERT_EQ(fast[i], ref[i]) << info(f).genicam << " " << w << "x" << h << " step " << step << " byte " << i
                                     << " (pixel " << (i / 3) % w << "," << (i / 3) / w << ")";
      }
}

TEST(Debayer, BadInputsAreValuesNotCrashes) {
  std::vector<std::uint8_t> raw(64), out(64 * 3);
  EXPECT_EQ(debayer({raw, 8, 8, 8, PixelFormat::kMono8}, ColorOrder::kRgb, out), DebayerStatus::kNotBayer8);
  EXPECT_EQ(debayer({raw, 8, 8, 8, PixelFormat::kBayerRG16}, ColorOrder::kRgb, out), DebayerStatus::kNotBayer8);
  EXPECT_EQ(debayer({raw, 1, 8, 8, PixelFormat::kBayerRG8}, ColorOrder::kRgb, out), DebayerStatus::kTooSmall);
  EXPECT_EQ(debayer({raw, 8, 9, 8, PixelFormat::kBayerRG8}, ColorOrder::kRgb, out), DebayerStatus::kShortInput);
  EXPECT_EQ(debayer({raw, 8, 8, 7, PixelFormat::kBayerRG8}, ColorOrder::kRgb, out), DebayerStatus::kShortInput);
  EXPECT_EQ(debayer({raw, 8, 8, 8, PixelFormat::kBayerRG8}, ColorOrder::kRgb, std::span(out).first(100)),
            DebayerStatus::kShortOutput);
  EXPECT_EQ(debayer_reference({raw, 8, 8, 8, PixelFormat::kMono8}, ColorOrder::kRgb, out), DebayerStatus::kNotBayer8);
}

}  // namespace
}  // namespace sensor_rig::camera
