// The shared percentile helpers: the nearest-rank convention of the monitor and the DBW bridge,
// linear interpolation of bench/perf, and the monitor's latency window over them.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "sensor_rig/common/latency_window.hpp"
#include "sensor_rig/common/percentile.hpp"

namespace sensor_rig {
namespace {

std::vector<double> one_to(int n) {
  std::vector<double> v;
  for (int i = 1; i <= n; ++i) v.push_back(i);
  return v;
}

TEST(Percentile, EmptyGivesZero) {
  const std::vector<double> none;
  EXPECT_EQ(nearest_rank_percentile(none, 0.5), 0.0);
  EXPECT_EQ(interpolated_percentile(none, 0.99), 0.0);
}

TEST(Percentile, OneSampleIsEveryPercentile) {
  const std::vector<double> one{7.5};
  for (double q : {0.0, 0.01, 0.5, 0.99, 1.0}) {
    EXPECT_EQ(nearest_rank_percentile(one, q), 7.5) << q;
    EXPECT_EQ(interpolated_percentile(one, q), 7.5) << q;
  }
}

TEST(Percentile, NearestRankRoundsTheIndexHalfUp) {
  const std::vector<double> four{10, 20, 30, 40};
  EXPECT_EQ(nearest_rank_percentile(four, 0.0), 10);
  EXPECT_EQ(nearest_rank_percentile(four, 0.5), 30);   // index 1.5 -> 2
  EXPECT_EQ(nearest_rank_percentile(four, 0.49), 20);  // index 1.47 -> 1
  EXPECT_EQ(nearest_rank_percentile(four, 0.99), 40);
  EXPECT_EQ(nearest_rank_percentile(four, 1.0), 40);
  const auto hundred = one_to(100);
  EXPECT_EQ(nearest_rank_percentile(hundred, 0.5), 51);   // index 49.5 -> 50
  EXPECT_EQ(nearest_rank_percentile(hundred, 0.99), 99);  // index 98.01 -> 98
  const std::vector<double> two{1, 2};
  EXPECT_EQ(nearest_rank_percentile(two, 0.5), 2);
}

TEST(Percentile, InterpolatesBetweenClosestRanks) {
  const std::vector<double> four{10, 20, 30, 40};
  EXPECT_DOUBLE_EQ(interpolated_percentile(four, 0.0), 10);
  EXPECT_DOUBLE_EQ(interpolated_percentile(four, 0.25), 17.5);  // index 0.75
  EXPECT_DOUBLE_EQ(interpolated_percentile(four, 0.5), 25);
  EXPECT_DOUBLE_EQ(interpolated_percentile(four, 1.0), 40);
  const auto hundred = one_to(100);
  EXPECT_DOUBLE_EQ(interpolated_percentile(hundred, 0.99), 99.01);
  EXPECT_DOUBLE_EQ(interpolated_percentile(hundred, 0.01), 1.99);
}

TEST(Percentile, QuantileOutsideZeroOneIsClamped) {
  const std::vector<double> three{1, 2, 3};
  EXPECT_EQ(nearest_rank_percentile(three, -0.5), 1);
  EXPECT_EQ(nearest_rank_percentile(three, 1.5), 3);
  EXPECT_EQ(interpolated_percentile(three, -2.0), 1);
  EXPECT_EQ(interpolated_percentile(three, 7.0), 3);
  EXPECT_EQ(nearest_rank_percentile(three, std::numeric_limits<double>::quiet_NaN()), 1);
}

TEST(LatencyWindow, SummarisesAndClears) {
  LatencyWindow w;
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(w.take().n, 0U);
  for (double v : {5.0, 1.0, 4.0, 2.0, 3.0}) w.add(v);
  const auto p = w.take();
  EXPECT_EQ(p.n, 5U);
  EXPECT_EQ(p.p50, 3.0);
  EXPECT_EQ(p.p99, 5.0);
  EXPECT_EQ(p.max, 5.0);
  EXPECT_TRUE(w.empty());
}

}  // namespace
}  // namespace sensor_rig
