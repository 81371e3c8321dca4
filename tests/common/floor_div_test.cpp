// floor_div / floor_mod against their definition: q is the floor of a / b, r = a - q * b, with r in
// [0, b) for b > 0 and in (b, 0] for b < 0. Truncating division (C++'s / and %) fails every case
// with a and b of opposite signs and a remainder.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig {
namespace {

TEST(FloorDiv, EverySmallPairMeetsTheDefinition) {
  for (std::int64_t b = -9; b <= 9; ++b) {
    if (b == 0) continue;
    for (std::int64_t a = -100; a <= 100; ++a) {
      const std::int64_t q = floor_div(a, b), r = floor_mod(a, b);
      EXPECT_EQ(q * b + r, a) << a << " / " << b;
      if (b > 0) {
        EXPECT_TRUE(r >= 0 && r < b) << a << " mod " << b << " = " << r;
      } else {
        EXPECT_TRUE(r <= 0 && r > b) << a << " mod " << b << " = " << r;
      }
    }
  }
}

TEST(FloorDiv, TimesBeforeTheirOriginFallInThePeriodBelow) {
  constexpr std::int64_t kHour = 3'600'000'000'000;
  EXPECT_EQ(floor_div(-1, kHour), -1);
  EXPECT_EQ(floor_mod(-1, kHour), kHour - 1);
  EXPECT_EQ(floor_div(-kHour, kHour), -1);
  EXPECT_EQ(floor_mod(-kHour, kHour), 0);
  EXPECT_EQ(floor_div(kHour - 1, kHour), 0);
  constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  static_assert(kMin % kHour != 0);  // so truncation and floor differ at the far end too
  EXPECT_EQ(floor_div(kMin, kHour), kMin / kHour - 1);
  EXPECT_EQ(floor_mod(kMin, kHour), kMin % kHour + kHour);
  EXPECT_EQ(floor_div(kMax, kHour), kMax / kHour);
  EXPECT_EQ(floor_mod(kMax, kHour), kMax % kHour);
  static_assert(floor_div(-7, 2) == -4 && floor_mod(-7, 2) == 1 && floor_div(7, -2) == -4 && floor_mod(7, -2) == -1);
}

}  // namespace
}  // namespace sensor_rig
