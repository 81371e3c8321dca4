// Phase lock: a synthetic LIDAR locked to an angle passes it on every whole second, so LIDARs of
// any vendor locked alike complete their scans together. Checked on the genuine packets through
// the vendors' decoders: each complete scan starts where the rotor crosses the cut, at the time the
// lock puts that crossing.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sensor_rig/lidar/mock/phase_lock.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr Nanos kSecond = 1'000'000'000;
// Not near a whole second, so the lock has to move the start.
constexpr Nanos kEarliest = 1'790'000'000LL * kSecond + 123'456'789;

// a mod m in [-m/2, m/2).
double centred_mod(double a, double m) { return a - m * std::floor(a / m + 0.5); }

SyntheticOptions options(const char* model, double phase_deg) {
  SyntheticOptions o;
  o.model = model;
  o.start_ns = kEarliest;
  o.phase_lock_deg = phase_deg;
  return o;
}

// Stamps (first firing) of the complete scans in `seconds` of the sensor's stream.
std::vector<Nanos> scan_stamps(const SyntheticOptions& o, SyntheticSensor& s, double seconds) {
  DecoderOptions d;
  d.model = o.model;
  if (is_ouster_model(o.model)) d.metadata_text = metadata_json(synthetic_ouster_metadata(o));
  auto dec = make_decoder(d);
  std::vector<Nanos> stamps;
  const auto packets = static_cast<int>(std::lround(seconds * s.packets_per_second()));
  for (int k = 0; k < packets;) {
    const SyntheticPacket p = s.next();
    if (p.position) continue;  // Velodyne GPRMC, Ouster IMU
    ++k;
    const SensorTime t = dec->packet_time(p.bytes);
    // Velodyne's µs-since-hour: the synthetic stream's own time is the packet's first firing.
    const Nanos stamp = t.kind == SensorTime::Kind::kAbsoluteNs ? t.value : p.time_ns;
    if (auto scan = dec->push(PacketView{p.bytes, p.time_ns, 0}, stamp)) stamps.push_back(scan->stamp);
  }
  EXPECT_EQ(dec->counters().dropped(), 0u);
  return stamps;
}

class PhaseLock : public ::testing::TestWithParam<const char*> {};

TEST_P(PhaseLock, ScansStartWhereTheLockPutsTheCut) {
  for (const double phase : {0.0, 45.5, 270.0}) {
    SCOPED_TRACE(phase);
    const SyntheticOptions o = options(GetParam(), phase);
    auto s = make_synthetic_sensor(o, Scene::standard());
    const double period = s->rotation_period_ns();
    const Nanos start = phase_locked_start_ns(*s, kEarliest, phase);
    EXPECT_GE(start, kEarliest);
    EXPECT_LT(static_cast<double>(start - kEarliest), period + 1.0);  // the earliest such start
    s->set_start_ns(start);
    for (Nanos sec = (start / kSecond + 1) * kSecond; sec < start + 3 * kSecond; sec += kSecond)
      EXPECT_NEAR(centred_mod(rotor_deg_at(*s, start, sec) - phase, 360.0), 0.0, 1e-6);

    const std::vector<Nanos> stamps = scan_stamps(o, *s, 0.45);
    ASSERT_GE(stamps.size(), 3u);
    // The rotor crosses the cut (0°) phase/360 of a turn before each whole second.
    const double crossing = -phase / 360.0 * period;
    // The Pandar40P cuts per point, and its channels look up to ~3.2° ahead of the rotor: a scan's
    // first point fires up to 0.9 ms before the rotor crosses. The others cut at the rotor's angle
    // (1 µs of rounding).
    const double earliest = std::string(GetParam()) == "Pandar40P" ? -1'000'000.0 : -1'000.0;
    for (const Nanos stamp : stamps) {
      const double off = centred_mod(static_cast<double>(stamp % kSecond) - crossing, period);
      EXPECT_GE(off, earliest) << stamp;
      EXPECT_LT(off, 150'000.0) << stamp;    // the first firing or column after it (< 0.55° at 600 rpm)
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EveryModel, PhaseLock,
                         ::testing::Values("VLP-16", "VLP-32C", "HDL-32E", "OS-LEGACY", "OS", "Pandar40P",
                                           "PandarXT32"),
                         [](const auto& i) {
                           std::string n = i.param;
                           for (char& c : n) c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           return n;
                         });

// Two sensors of different vendors and start times, locked alike, complete their scans together.
TEST(PhaseLockPair, DifferentVendorsLockedAlikeCompleteTogether) {
  SyntheticOptions a = options("VLP-32C", 0.0), b = options("OS-LEGACY", 0.0);
  b.start_ns = kEarliest + 37'000'000;
  auto sa = make_synthetic_sensor(a, Scene::standard());
  auto sb = make_synthetic_sensor(b, Scene::standard());
  sa->set_start_ns(phase_locked_start_ns(*sa, a.start_ns, 0.0));
  sb->set_start_ns(phase_locked_start_ns(*sb, b.start_ns, 0.0));
  const auto ta = scan_stamps(a, *sa, 0.5), tb = scan_stamps(b, *sb, 0.5);
  ASSERT_GE(ta.size(), 3u);
  ASSERT_GE(tb.size(), 3u);
  int compared = 0;
  for (const Nanos t : tb) {
    if (t < ta.front() || t > ta.back()) continue;  // outside the other's stream
    ++compared;
    double nearest = 1e18;
    for (const Nanos u : ta) nearest = std::min(nearest, std::abs(static_cast<double>(t - u)));
    EXPECT_LT(nearest, 150'000.0) << t;
  }
  EXPECT_GE(compared, 3);
}

TEST(PhaseLock, RefusesWhatCannotLock) {
  SyntheticOptions o = options("VLP-16", 10.0);
  o.rpm = 700;  // 11.67 turns per second: no angle recurs on every second
  EXPECT_NE(synthetic_options_error(o).find("whole number of turns per second"), std::string::npos)
      << synthetic_options_error(o);
  o.rpm = 900;  // 15 per second
  EXPECT_EQ(synthetic_options_error(o), "");
  o.phase_lock_deg = 360.0;
  EXPECT_NE(synthetic_options_error(o).find("[0, 360)"), std::string::npos);
  o.phase_lock_deg = -1.0;
  EXPECT_NE(synthetic_options_error(o).find("[0, 360)"), std::string::npos);
  EXPECT_NE(phase_lock_error(0.0), "");
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
