#include "sensor_rig/camera/debayer.hpp"

#include <array>
#include <cstddef>

namespace sensor_rig::camera {
namespace {

// Colour of each site of the 2x2 tile, [y & 1][x & 1]: 0 = R, 1 = G, 2 = B.
using Tile = std::array<std::array<int, 2>, 2>;

Tile tile_of(PixelFormat f) noexcept {
  switch (f) {
    case PixelFormat::kBayerRG8: return {{{0, 1}, {1, 2}}};
    case PixelFormat::kBayerBG8: return {{{2, 1}, {1, 0}}};
    case PixelFormat::kBayerGR8: return {{{1, 0}, {2, 1}}};
    case PixelFormat::kBayerGB8: return {{{1, 2}, {0, 1}}};
    default: return {{{1, 1}, {1, 1}}};
  }
}

// Reflect-101: -1 -> 1, n -> n - 2 (keeps the Bayer phase; needs n >= 2).
inline std::int64_t reflect(std::int64_t i, std::int64_t n) noexcept {
  if (i < 0) return -i;
  if (i >= n) return 2 * (n - 1) - i;
  return i;
}

DebayerStatus check(const ImageIn& in, std::span<std::uint8_t> out) noexcept {
  if (!is_bayer8(in.format)) return DebayerStatus::kNotBayer8;
  if (in.width < 2 || in.height < 2) return DebayerStatus::kTooSmall;
  if (in.step < in.width || in.data.size() < static_cast<std::size_t>(in.step) * in.height) return DebayerStatus::kShortInput;
  if (out.size() < static_cast<std::size_t>(in.width) * in.height * 3) return DebayerStatus::kShortOutput;
  return DebayerStatus::kOk;
}

// Output byte offsets of R, G, B within a pixel.
struct Offsets {
  int r, g, b;
};
Offsets offsets(ColorOrder o) noexcept { return o == ColorOrder::kRgb ? Offsets{0, 1, 2} : Offsets{2, 1, 0}; }

}  // namespace

const char* ros_encoding(ColorOrder o) noexcept { return o == ColorOrder::kRgb ? "rgb8" : "bgr8"; }

const char* to_string(DebayerStatus s) noexcept {
  switch (s) {
    case DebayerStatus::kOk: return "ok";
    case DebayerStatus::kNotBayer8: return "not an 8-bit Bayer format";
    case DebayerStatus::kTooSmall: return "image smaller than 2x2";
    case DebayerStatus::kShortInput: return "input shorter than step x height";
    case DebayerStatus::kShortOutput: return "output shorter than width x height x 3";
  }
  return "?";
}

bool is_bayer8(PixelFormat f) noexcept {
  return f == PixelFormat::kBayerRG8 || f == PixelFormat::kBayerGR8 || f == PixelFormat::kBayerGB8 ||
         f == PixelFormat::kBayerBG8;
}

// The definition, per pixel and channel: own value, or the rounded mean of the same-colour sites of
// the 3x3 neighbourhood (reflect-101 coordinates, a mirrored site counts as often as it is reached).
DebayerStatus debayer_reference(const ImageIn& in, ColorOrder order, std::span<std::uint8_t> out) noexcept {
  if (const auto s = check(in, out); s != DebayerStatus::kOk) return s;
  const Tile tile = tile_of(in.format);
  const Offsets o = offsets(order);
  const std::array<int, 3> channel_offset{o.r, o.g, o.b};
  const std::int64_t w = in.width;
  const std::int64_t h = in.height;
  for (std::int64_t y = 0; y < h; ++y) {
    for (std::int64_t x = 0; x < w; ++x) {
      const int own = tile[static_cast<std::size_t>(y & 1)][static_cast<std::size_t>(x & 1)];
      std::uint8_t* px = out.data() + (y * w + x) * 3;
      for (int c = 0; c < 3; ++c) {
        unsigned value = 0;
        if (c == own) {
          value = in.data[static_cast<std::size_t>(y * in.step + x)];
        } else {
          unsigned sum = 0;
          unsigned n = 0;
          for (std::int64_t dy = -1; dy <= 1; ++dy)
            for (std::int64_t dx = -1; dx <= 1; ++dx) {
              const std::int64_t yy = reflect(y + dy, h);
              const std::int64_t xx = reflect(x + dx, w);
              if (tile[static_cast<std::size_t>(yy & 1)][static_cast<std::size_t>(xx & 1)] != c) continue;
              sum += in.data[static_cast<std::size_t>(yy * in.step + xx)];
              ++n;
            }
          value = (sum + n / 2) / n;
        }
        px[channel_offset[static_cast<std::size_t>(c)]] = static_cast<std::uint8_t>(value);
      }
    }
  }
  return DebayerStatus::kOk;
}

namespace {

// One output row. u/m/d: the rows above, at and below (already reflected). `c_off`/`o_off`: output
// offsets of the row's non-green colour (C) and of the other one (O, on the rows above and below);
// `phase`: x parity of the C sites. Border columns take the reflected neighbours; the interior runs
// two pixels per step without branches.
void row(const std::uint8_t* u, const std::uint8_t* m, const std::uint8_t* d, std::uint32_t w, unsigned phase, int c_off,
         int g_off, int o_off, std::uint8_t* out) noexcept {
  auto at_c = [&](std::uint8_t* px, unsigned l, unsigned x, unsigned r) {  // a C site
    px[c_off] = m[x];
    px[g_off] = static_cast<std::uint8_t>((u[x] + d[x] + m[l] + m[r] + 2u) >> 2);
    px[o_off] = static_cast<std::uint8_t>((u[l] + u[r] + d[l] + d[r] + 2u) >> 2);
  };
  auto at_g = [&](std::uint8_t* px, unsigned l, unsigned x, unsigned r) {  // a green site
    px[g_off] = m[x];
    px[c_off] = static_cast<std::uint8_t>((m[l] + m[r] + 1u) >> 1);
    px[o_off] = static_cast<std::uint8_t>((u[x] + d[x] + 1u) >> 1);
  };
  auto pixel = [&](unsigned x) {
    const unsigned l = static_cast<unsigned>(reflect(static_cast<std::int64_t>(x) - 1, w));
    const unsigned r = static_cast<unsigned>(reflect(static_cast<std::int64_t>(x) + 1, w));
    if ((x & 1u) == phase)
      at_c(out + 3 * x, l, x, r);
    else
      at_g(out + 3 * x, l, x, r);
  };
  pixel(0);
  unsigned x = 1;
  if (phase == 1) {  // x = 1, 3, ...: C then G
    for (; x + 2 < w; x += 2) {
      std::uint8_t* px = out + 3 * x;
      px[c_off] = m[x];
      px[g_off] = static_cast<std::uint8_t>((u[x] + d[x] + m[x - 1] + m[x + 1] + 2u) >> 2);
      px[o_off] = static_cast<std::uint8_t>((u[x - 1] + u[x + 1] + d[x - 1] + d[x + 1] + 2u) >> 2);
      px[3 + g_off] = m[x + 1];
      px[3 + c_off] = static_cast<std::uint8_t>((m[x] + m[x + 2] + 1u) >> 1);
      px[3 + o_off] = static_cast<std::uint8_t>((u[x + 1] + d[x + 1] + 1u) >> 1);
    }
  } else {  // x = 1, 3, ...: G then C
    for (; x + 2 < w; x += 2) {
      std::uint8_t* px = out + 3 * x;
      px[g_off] = m[x];
      px[c_off] = static_cast<std::uint8_t>((m[x - 1] + m[x + 1] + 1u) >> 1);
      px[o_off] = static_cast<std::uint8_t>((u[x] + d[x] + 1u) >> 1);
      px[3 + c_off] = m[x + 1];
      px[3 + g_off] = static_cast<std::uint8_t>((u[x + 1] + d[x + 1] + m[x] + m[x + 2] + 2u) >> 2);
      px[3 + o_off] = static_cast<std::uint8_t>((u[x] + u[x + 2] + d[x] + d[x + 2] + 2u) >> 2);
    }
  }
  for (; x < w; ++x) pixel(x);
}

}  // namespace

DebayerStatus debayer(const ImageIn& in, ColorOrder order, std::span<std::uint8_t> out) noexcept {
  if (const auto s = check(in, out); s != DebayerStatus::kOk) return s;
  const Tile tile = tile_of(in.format);
  const Offsets o = offsets(order);
  const std::uint32_t w = in.width;
  const std::uint32_t h = in.height;
  const std::uint8_t* base = in.data.data();
  for (std::uint32_t y = 0; y < h; ++y) {
    const auto& t = tile[y & 1u];
    const unsigned phase = t[0] == 1 ? 1u : 0u;  // x parity of the non-green sites
    const int c = t[phase];                       // 0 = R row, 2 = B row
    const int c_off = c == 0 ? o.r : o.b;
    const int o_off = c == 0 ? o.b : o.r;
    const auto yu = static_cast<std::uint32_t>(reflect(static_cast<std::int64_t>(y) - 1, h));
    const auto yd = static_cast<std::uint32_t>(reflect(static_cast<std::int64_t>(y) + 1, h));
    row(base + static_cast<std::size_t>(yu) * in.step, base + static_cast<std::size_t>(y) * in.step,
        base + static_cast<std::size_t>(yd) * in.step, w, phase, c_off, o.g, o_off,
        out.data() + static_cast<std::size_t>(y) * w * 3);
  }
  return DebayerStatus::kOk;
}

}  // namespace sensor_rig::camera
