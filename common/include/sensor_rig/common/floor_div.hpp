#pragma once
// Integer division and remainder rounded toward negative infinity. C++'s `/` and `%` truncate toward
// zero, so a time before its origin (a clock stepped back, a phase ahead of its boundary, a date
// before 1970) would land in the period above it. One definition for the period arithmetic of the
// mocks, the clock mapper, the fusion matcher and the campaign's judge.
#include <cstdint>

namespace sensor_rig {

// The largest integer q with q * b <= a (b > 0); for b < 0, the smallest with q * b >= a.
constexpr std::int64_t floor_div(std::int64_t a, std::int64_t b) noexcept {
  const std::int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

// a - floor_div(a, b) * b: in [0, b) for b > 0, in (b, 0] for b < 0.
constexpr std::int64_t floor_mod(std::int64_t a, std::int64_t b) noexcept {
  const std::int64_t r = a % b;
  return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r;
}

}  // namespace sensor_rig
