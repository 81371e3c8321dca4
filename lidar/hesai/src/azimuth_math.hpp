#pragma once
// The Hesai decoder's azimuth arithmetic (0.01° block azimuths, a turn of kAzimuthCount): forward
// steps, cut crossings, sectors, and the sin/cos table of every block azimuth. Private to
// decoder.cpp (one translation unit: the anonymous namespace costs nothing).
#include <array>
#include <cmath>
#include <numbers>

#include "sensor_rig/lidar/hesai/packet.hpp"

namespace sensor_rig::lidar::hesai {
namespace {

// sin/cos of every block azimuth (0.01°), built once, read-only.
struct AngleTable {
  std::array<float, kAzimuthCount> sin{};
  std::array<float, kAzimuthCount> cos{};
  AngleTable() noexcept {
    for (std::size_t i = 0; i < sin.size(); ++i) {
      const double a = static_cast<double>(i) * (std::numbers::pi / 18000.0);
      sin[i] = static_cast<float>(std::sin(a));
      cos[i] = static_cast<float>(std::cos(a));
    }
  }
};
const AngleTable& angles() noexcept {
  static const AngleTable kTable;
  return kTable;
}

// Forward step from a to b in 0.01°, in [0, 36000).
inline int az_step(int a, int b) noexcept {
  const int d = b - a;
  return d < 0 ? d + kAzimuthCount : d;
}
// `target` in (prev, prev + step] on a forward step shorter than half a turn (any forward step
// when `any_length`: the first group after a judged gap).
inline bool crosses(int prev, int step, int target, bool any_length = false) noexcept {
  if (step <= 0 || (step >= kAzimuthCount / 2 && !any_length)) return false;
  const int to = az_step(prev, target);
  return to > 0 && to <= step;
}
inline bool in_sector(int start, int end, int a) noexcept {  // inclusive, may wrap
  return start <= end ? (a >= start && a <= end) : (a >= start || a <= end);
}
inline int norm_az(long v) noexcept {
  v %= kAzimuthCount;
  return static_cast<int>(v < 0 ? v + kAzimuthCount : v);
}
inline long round_away(double v) noexcept { return static_cast<long>(v < 0 ? std::floor(v) : std::ceil(v)); }

}  // namespace
}  // namespace sensor_rig::lidar::hesai
