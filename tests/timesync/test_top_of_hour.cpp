#include "sensor_rig/timesync/top_of_hour.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <stdexcept>

#include "sensor_rig/common/clock.hpp"
#include "test_instants.hpp"

namespace sensor_rig::timesync {
namespace {
using test::kHour10;
using test::us_of;
constexpr Nanos kMin = 60 * kSec;

TEST(NearestHourTime, PicksTheHourClosestToTheReference) {
  ASSERT_EQ(kHour10 % kHourNs, 0);
  const std::uint32_t twenty = 20u * 60u * 1'000'000u;
  EXPECT_EQ(nearest_hour_time(twenty, kHour10 + 20 * kMin + 3 * kMs), kHour10 + 20 * kMin);
  // Sensor just past the hour, host a little before it: the next hour.
  EXPECT_EQ(nearest_hour_time(100'000, kHour10 + kHourNs - 100 * kMs), kHour10 + kHourNs + 100 * kMs);
  // Sensor just before the hour, host just after: the previous hour.
  EXPECT_EQ(nearest_hour_time(kMicrosPerHour - 50'000, kHour10 + 50 * kMs), kHour10 - 50 * kMs);
  // 29 minutes apart is still the same hour either way.
  EXPECT_EQ(nearest_hour_time(0, kHour10 + 29 * kMin), kHour10);
  EXPECT_EQ(nearest_hour_time(0, kHour10 - 29 * kMin), kHour10);
  EXPECT_EQ(nearest_hour_time(0, kHour10 + 31 * kMin), kHour10 + kHourNs);
}

TEST(TopOfHourClock, HostHourAcrossTheHourlyWrap) {
  TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
  Nanos prev = 0;
  int n = 0;
  for (Nanos t = kHour10 + kHourNs - 200 * kMs; t < kHour10 + kHourNs + 200 * kMs; t += 1327 * kUs, ++n) {
    const HourResult r = c.resolve(us_of(t), t + 700 * kUs, std::nullopt);
    ASSERT_EQ(r.status, HourStatus::kOk);
    EXPECT_EQ(r.source, HourSource::kHost);
    EXPECT_EQ(r.sensor_ns, t - t % 1000);
    if (n > 0) {
      EXPECT_GT(r.sensor_ns, prev);
    }
    prev = r.sensor_ns;
  }
  EXPECT_EQ(c.stats().wraps, 1u);
  EXPECT_EQ(c.stats().backward_changes, 0u);
  EXPECT_EQ(c.stats().hour_start_ns, kHour10 + kHourNs);
}

TEST(TopOfHourClock, HostAndSensorEitherSideOfTheBoundary) {
  {  // sensor already in the new hour, host clock 0.4 ms behind and still in the old one
    TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
    const Nanos t = kHour10 + kHourNs + 200 * kUs;
    const HourResult r = c.resolve(us_of(t), t - 400 * kUs, std::nullopt);
    EXPECT_EQ(r.sensor_ns, t);
  }
  {  // sensor at the end of the old hour, host already in the new one
    TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
    const Nanos t = kHour10 + kHourNs - 300 * kUs;
    const HourResult r = c.resolve(us_of(t), t + 900 * kUs, std::nullopt);
    EXPECT_EQ(r.sensor_ns, t);
  }
}

TEST(TopOfHourClock, GprmcPlacesPacketsEitherSideOfTheBoundary) {
  TopOfHourClock c;  // kGprmc
  // Sentence "10:59:59" (whole seconds), data packet already at 11:00:00.5.
  Nanos t = kHour10 + kHourNs + 500 * kMs;
  HourResult r = c.resolve(us_of(t), t + kMs, kHour10 + kHourNs - kSec);
  EXPECT_EQ(r.source, HourSource::kGprmc);
  EXPECT_EQ(r.sensor_ns, t);
  // Sentence "11:00:00" arriving before a late packet from 10:59:59.99.
  TopOfHourClock c2;
  t = kHour10 + kHourNs - 10 * kMs;
  r = c2.resolve(us_of(t), t + kMs, kHour10 + kHourNs);
  EXPECT_EQ(r.sensor_ns, t);
}

TEST(TopOfHourClock, GprmcWinsOverAWrongHostClock) {
  const Nanos host_error = 2 * kHourNs + 7 * kMin;  // PU clock not yet synchronised
  TopOfHourClock gps;
  TopOfHourClock host(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
  const Nanos t = kHour10 + 42 * kMin;
  const HourResult g = gps.resolve(us_of(t), t + host_error, t - 300 * kMs);
  const HourResult h = host.resolve(us_of(t), t + host_error, t - 300 * kMs);
  EXPECT_EQ(g.sensor_ns, t);
  EXPECT_EQ(g.source, HourSource::kGprmc);
  EXPECT_EQ(h.sensor_ns, t + 2 * kHourNs);  // host mode trusts the host's hour by design
  EXPECT_EQ(h.source, HourSource::kHost);
}

TEST(TopOfHourClock, GprmcModeFallsBackToHostAndCorrectsWhenTheSentenceArrives) {
  TopOfHourClock c;
  const Nanos host_error = 3 * kHourNs;
  Nanos t = kHour10 + 5 * kMin;
  HourResult r = c.resolve(us_of(t), t + host_error, std::nullopt);
  EXPECT_EQ(r.source, HourSource::kHost);
  EXPECT_EQ(r.sensor_ns, t + 3 * kHourNs);
  t += 100 * kMs;
  r = c.resolve(us_of(t), t + host_error, std::nullopt);
  EXPECT_EQ(r.source, HourSource::kHost);  // continuity keeps the anchor's source
  t += 100 * kMs;
  r = c.resolve(us_of(t), t + host_error, t - 600 * kMs);
  EXPECT_EQ(r.source, HourSource::kGprmc);
  EXPECT_EQ(r.sensor_ns, t);
  EXPECT_EQ(c.stats().corrections, 1u);
  EXPECT_EQ(c.stats().backward_changes, 1u);
}

TEST(TopOfHourClock, GprmcRequiredWithoutFallback) {
  TopOfHourClock c(TopOfHourConfig{HourSource::kGprmc, false, 10 * kSec});
  const Nanos t = kHour10 + kMin;
  EXPECT_EQ(c.resolve(us_of(t), t, std::nullopt).status, HourStatus::kNoReference);
  EXPECT_EQ(c.stats().no_reference, 1u);
  EXPECT_EQ(c.resolve(us_of(t), t, t).status, HourStatus::kOk);
}

TEST(TopOfHourClock, AgesAStaleSentenceByHostTime) {
  // The sentence is only refreshed once per second (or stops); the reference advances with the
  // host receive time, so 25 minutes of packets against one sentence still land right.
  TopOfHourClock c(TopOfHourConfig{HourSource::kGprmc, true, 10 * kSec});
  const Nanos fix = kHour10 + 50 * kMin;
  for (Nanos t = fix; t < fix + 25 * kMin; t += 7 * kSec) {
    const HourResult r = c.resolve(us_of(t), t + kMs + 20 * kSec, fix);  // host 20 s ahead
    ASSERT_EQ(r.sensor_ns, t) << (t - fix) / kSec;
  }
}

TEST(TopOfHourClock, ContinuityKeepsTheHourOfAFreeRunningSensorNearHalfAnHourOff) {
  // A sensor without GPS: its hour phase is arbitrary. Here its clock leads the host by almost
  // 30 minutes and gains (a caricature of drift, 0.2 s per second) so the offset crosses 30 min.
  // Nearest-to-host alone would flip the hour; continuity must not.
  TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
  const Nanos host0 = kHour10 + 3 * kMin;
  const Nanos sensor0 = host0 + 30 * kMin - 500 * kMs;
  Nanos prev = 0;
  for (int i = 0; i < 100; ++i) {
    const Nanos host = host0 + i * 50 * kMs;
    const Nanos sensor = sensor0 + i * 60 * kMs;
    const HourResult r = c.resolve(us_of(sensor), host, std::nullopt);
    if (i > 0) {
      ASSERT_EQ(r.sensor_ns - prev, 60 * kMs) << i;
    }
    prev = r.sensor_ns;
  }
  EXPECT_EQ(c.stats().wraps + c.stats().backward_changes, 0u);
}

TEST(TopOfHourClock, LongGapReanchorsFromTheHost) {
  TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
  const Nanos t = kHour10 + kMin;
  c.resolve(us_of(t), t, std::nullopt);
  // After 20 s of silence the sensor (power-cycled, new phase) is re-anchored to the host.
  const Nanos t2 = t + 20 * kSec;
  const Nanos sensor = t2 + 40 * kMin;
  const HourResult r = c.resolve(us_of(sensor), t2, std::nullopt);
  EXPECT_EQ(r.sensor_ns, sensor - kHourNs);
}

TEST(TopOfHourClock, ReorderedPacketsAcrossTheBoundary) {
  TopOfHourClock c(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
  const Nanos b = kHour10 + kHourNs;
  const Nanos times[] = {b - 2 * kMs, b + 1 * kMs, b - 1 * kMs, b + 2 * kMs};
  Nanos rx = b + 10 * kMs;
  for (Nanos t : times) {
    EXPECT_EQ(c.resolve(us_of(t), rx, std::nullopt).sensor_ns, t);
    rx += 50 * kUs;
  }
  EXPECT_EQ(c.stats().wraps, 1u);
  EXPECT_EQ(c.stats().backward_changes, 1u);
}

TEST(TopOfHourClock, BadTimestampsAreCountedNotUsed) {
  TopOfHourClock c;
  const HourResult r = c.resolve(kMicrosPerHour, kHour10, std::nullopt);
  EXPECT_EQ(r.status, HourStatus::kBadTimestamp);
  EXPECT_EQ(c.resolve(0xFFFFFFFFu, kHour10, kHour10).status, HourStatus::kBadTimestamp);
  EXPECT_EQ(c.stats().bad_timestamps, 2u);
  EXPECT_EQ(c.stats().packets, 2u);
  // Extreme host and GPRMC values stay defined.
  EXPECT_EQ(c.resolve(5, INT64_MIN, INT64_MAX).status, HourStatus::kOk);
  EXPECT_EQ(c.resolve(5, INT64_MAX, INT64_MIN).status, HourStatus::kOk);
}

TEST(TopOfHourClock, RandomizedTimesResolveExactly) {
  std::mt19937_64 rng(4242);
  std::uniform_int_distribution<Nanos> when(0, 400LL * 24 * kHourNs);
  std::uniform_int_distribution<Nanos> host_off(-25 * kMin, 25 * kMin);
  std::uniform_int_distribution<Nanos> age(0, 2 * kSec);
  for (int i = 0; i < 2000; ++i) {
    const Nanos t = kHour10 + when(rng) / 1000 * 1000;
    TopOfHourClock host(TopOfHourConfig{HourSource::kHost, true, 10 * kSec});
    TopOfHourClock gps;
    const Nanos rx = t + host_off(rng);
    ASSERT_EQ(host.resolve(us_of(t), rx, std::nullopt).sensor_ns, t) << i;
    ASSERT_EQ(gps.resolve(us_of(t), rx + kHourNs * 5, t - age(rng)).sensor_ns, t) << i;
  }
}

TEST(TopOfHourClock, ConfigValidation) {
  EXPECT_THROW(TopOfHourClock(TopOfHourConfig{HourSource::kNone, true, kSec}), std::invalid_argument);
  EXPECT_THROW(TopOfHourClock(TopOfHourConfig{HourSource::kHost, true, 0}), std::invalid_argument);
  EXPECT_THROW(TopOfHourClock(TopOfHourConfig{HourSource::kHost, true, kHourNs}), std::invalid_argument);
}

}  // namespace
}  // namespace sensor_rig::timesync
