#include "sensor_rig/timesync/stamper.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <stdexcept>

#include "sensor_rig/common/clock.hpp"
#include "sim_clock.hpp"
#include "test_instants.hpp"

namespace sensor_rig::timesync {
namespace {
using test::kHour10;
using test::us_of;

using test::DelayModel;
using test::SimDevice;
using test::SimLink;
constexpr Nanos kVlp16Packet = 1'327'104;               // 12 blocks x 55.296 µs
constexpr Nanos kPeriod = 1'327'104;                    // VLP-16 strongest: one packet per span

StamperConfig vlp16(TimeSource src) {
  StamperConfig c;
  c.source = src;
  c.packet_duration_ns = kVlp16Packet;
  c.host_latency_ns = 150 * kUs;
  return c;
}

TEST(Stamper, HostModeSubtractsThePacketDurationAndLatency) {
  Stamper s(vlp16(TimeSource::kHost));
  const Stamp st = s.stamp(PacketTime{123, kHour10 + 5 * kSec, std::nullopt, PpsState::kUnknown});
  EXPECT_EQ(st.vehicle_ns, kHour10 + 5 * kSec - kVlp16Packet - 150 * kUs);
  EXPECT_EQ(st.source, StampSource::kHost);
  EXPECT_TRUE(st.ok);
  EXPECT_EQ(s.status().mode, TimeSource::kHost);
  EXPECT_EQ(s.status().last_source, StampSource::kHost);
}

TEST(Stamper, GpsSynchronisedSensorTimeIsVehicleTime) {
  Stamper s(vlp16(TimeSource::kSensor));
  DelayModel dm;
  SimLink link(1, dm);
  for (int i = 0; i < 2000; ++i) {
    const Nanos first = kHour10 + 17 * 60 * kSec + i * kPeriod;  // µs resolution on the wire
    const Nanos rx = first + kVlp16Packet + link.delay();
    const Stamp st = s.stamp(PacketTime{us_of(first), rx, first / kSec * kSec - kSec, PpsState::kLocked});
    ASSERT_EQ(st.vehicle_ns, first - first % 1000);
    ASSERT_EQ(st.source, StampSource::kGps);
    ASSERT_EQ(st.sync, SyncState::kLocked);
  }
  const StamperStatus st = s.status();
  EXPECT_EQ(st.hour_source, HourSource::kGprmc);
  EXPECT_EQ(st.sync, SyncState::kLocked);
  EXPECT_TRUE(st.gprmc);
  EXPECT_EQ(st.pps, PpsState::kLocked);
  // The mapper still watches the sensor against the host: ~0 offset for a GPS-synced sensor.
  EXPECT_EQ(st.mapper.state, SyncState::kLocked);
  EXPECT_LT(std::abs(st.mapper.offset_ns), 50 * kUs);
}

TEST(Stamper, FreeRunningSensorIsMappedToVehicleTime) {
  StamperConfig cfg = vlp16(TimeSource::kSensor);
  Stamper s(cfg);
  DelayModel dm;  // base 150 µs = host_latency_ns
  SimLink link(2, dm);
  SimDevice dev;  // sensor clock: arbitrary phase within the hour, 80 ppm fast
  dev.t0 = kHour10 + 11 * 60 * kSec;
  dev.device0 = kHour10 + 28 * 60 * kSec + 123'456'789;
  dev.drift_ppm = 80;
  Nanos max_err = 0;
  Nanos prev = 0;
  for (int i = 0; i < 6000; ++i) {
    const Nanos first = dev.t0 + i * kPeriod;
    const Nanos sensor = dev.device_at(first);
    const Nanos rx = first + kVlp16Packet + link.delay();
    const Stamp st = s.stamp(PacketTime{us_of(sensor), rx, std::nullopt, PpsState::kAbsent});
    ASSERT_EQ(st.source, StampSource::kSensorMapped);
    ASSERT_TRUE(st.ok);
    if (i == 0) {
      EXPECT_LT(std::abs(st.vehicle_ns - first), 2 * kMs);  // usable at once
    }
    if (i > 1600) {  // ~2 s
      EXPECT_EQ(st.sync, SyncState::kLocked);
      max_err = std::max(max_err, std::abs(st.vehicle_ns - first));
    }
    prev = st.vehicle_ns;
  }
  (void)prev;
  EXPECT_LT(max_err, 50 * kUs);
  const StamperStatus st = s.status();
  EXPECT_EQ(st.hour_source, HourSource::kHost);  // no GPRMC: host hour fallback
  EXPECT_NEAR(st.mapper.drift_ppm, 80, 5);
  EXPECT_EQ(st.host_fallbacks, 0u);
}

TEST(Stamper, LosingPpsSwitchesToTheMappedClockWithoutAStep) {
  Stamper s(vlp16(TimeSource::kSensor));
  DelayModel dm;
  SimLink link(3, dm);
  Nanos last_gps = 0;
  int i = 0;
  for (; i < 4000; ++i) {
    const Nanos first = kHour10 + 59 * 60 * kSec + i * kPeriod;
    const Stamp st = s.stamp(PacketTime{us_of(first), first + kVlp16Packet + link.delay(),
                                        first / kSec * kSec, PpsState::kLocked});
    ASSERT_EQ(st.source, StampSource::kGps);
    last_gps = st.vehicle_ns;
  }
  // PPS lost, GPRMC gone: the mapper (locked all along) takes over.
  const Nanos first = kHour10 + 59 * 60 * kSec + i * kPeriod;
  const Stamp st = s.stamp(PacketTime{us_of(first), first + kVlp16Packet + link.delay(),
                                      std::nullopt, PpsState::kAbsent});
  EXPECT_EQ(st.source, StampSource::kSensorMapped);
  EXPECT_EQ(st.sync, SyncState::kLocked);
  EXPECT_LT(std::abs(st.vehicle_ns - first), 50 * kUs);
  EXPECT_GT(st.vehicle_ns, last_gps);
}

TEST(Stamper, StampsStayMonotonicAcrossTheHourlyWrap) {
  for (const HourSource hs : {HourSource::kGprmc, HourSource::kHost}) {
    StamperConfig cfg = vlp16(TimeSource::kSensor);
    cfg.hour.hour_source = hs;
    Stamper s(cfg);
    DelayModel dm;
    SimLink link(4, dm);
    const Nanos start = kHour10 + kHourNs - 3 * kSec;
    for (int i = 0; i < 4000; ++i) {
      const Nanos first = start + i * kPeriod;
      // The GPRMC sentence carries whole seconds and lags up to a second.
      const Stamp st = s.stamp(PacketTime{us_of(first), first + kVlp16Packet + link.delay(),
                                          first / kSec * kSec - kSec, PpsState::kLocked});
      ASSERT_EQ(st.vehicle_ns, first - first % 1000) << i;
    }
    const StamperStatus st = s.status();
    EXPECT_EQ(st.backwards, 0u);
    EXPECT_EQ(st.hour.wraps, 1u);
    EXPECT_EQ(st.mapper.jumps, 0u);
    EXPECT_EQ(st.hour_source, hs == HourSource::kGprmc ? HourSource::kGprmc : HourSource::kHost);
  }
}

TEST(Stamper, BadSensorTimestampsFallBackToHostTime) {
  Stamper s(vlp16(TimeSource::kSensor));
  const Stamp st = s.stamp(PacketTime{kMicrosPerHour + 5, kHour10, std::nullopt, PpsState::kAbsent});
  EXPECT_FALSE(st.ok);
  EXPECT_EQ(st.source, StampSource::kHostFallback);
  EXPECT_EQ(st.vehicle_ns, kHour10 - kVlp16Packet - 150 * kUs);
  EXPECT_EQ(s.status().bad_timestamps, 1u);
  EXPECT_EQ(s.status().host_fallbacks, 1u);
  // Garbage receive times stay defined.
  (void)s.stamp(PacketTime{0, INT64_MIN, INT64_MAX, PpsState::kError});
  (void)s.stamp(PacketTime{0, INT64_MAX, INT64_MIN, PpsState::kLocked});
  EXPECT_EQ(s.status().packets, 3u);
}

TEST(Stamper, CorrectionNeverUsesTheRawSensorClock) {
  StamperConfig cfg = vlp16(TimeSource::kSensor);
  cfg.correction = Correction::kNever;
  Stamper s(cfg);
  const Nanos sensor = kHour10 + 7 * 60 * kSec;
  const Stamp st = s.stamp(PacketTime{us_of(sensor), sensor + 4 * kMs, std::nullopt, PpsState::kAbsent});
  EXPECT_EQ(st.source, StampSource::kSensorRaw);
  EXPECT_EQ(st.vehicle_ns, sensor);
}

TEST(Stamper, CorrectionAlwaysMapsEvenAGpsSyncedSensor) {
  StamperConfig cfg = vlp16(TimeSource::kSensor);
  cfg.correction = Correction::kAlways;
  Stamper s(cfg);
  const Nanos sensor = kHour10 + 7 * 60 * kSec;
  const Stamp st = s.stamp(PacketTime{us_of(sensor), sensor + kVlp16Packet + 150 * kUs, sensor,
                                      PpsState::kLocked});
  EXPECT_EQ(st.source, StampSource::kSensorMapped);
  EXPECT_EQ(st.sync, SyncState::kConverging);
  EXPECT_EQ(st.vehicle_ns, sensor);
}

TEST(Stamper, ConfigValidation) {
  StamperConfig c;
  c.packet_duration_ns = -1;
  EXPECT_THROW(Stamper{c}, std::invalid_argument);
  c = {};
  c.host_latency_ns = 2 * kSec;
  EXPECT_THROW(Stamper{c}, std::invalid_argument);
  c = {};
  c.mapper.window_buckets = 1;
  EXPECT_THROW(Stamper{c}, std::invalid_argument);
  c = {};
  c.hour.hour_source = HourSource::kNone;
  EXPECT_THROW(Stamper{c}, std::invalid_argument);
}

TEST(Stamper, EnumNamesForDiagnostics) {
  EXPECT_STREQ(to_string(StampSource::kSensorMapped), "sensor_mapped");
  EXPECT_STREQ(to_string(TimeSource::kHost), "host");
  EXPECT_STREQ(to_string(Correction::kAuto), "auto");
  EXPECT_STREQ(to_string(PpsState::kLocked), "locked");
  EXPECT_STREQ(to_string(HourSource::kGprmc), "gprmc");
  EXPECT_STREQ(to_string(SyncState::kHoldover), "holdover");
  EXPECT_STREQ(to_string(HourStatus::kBadTimestamp), "bad_timestamp");
}

}  // namespace
}  // namespace sensor_rig::timesync
