// CLOCK_REALTIME steps while a LIDAR runs, with an injected host clock: the stamper's mapping
// follows the step (vehicle time is the stepped clock), RealtimeStepDetector counts it and tells
// the per-topic MonotonicStamps, which keeps the published stamps from going backwards (a step
// back is slewed out at 10 % of elapsed time; a step forward passes at once); a device's own
// backward jump, with no host step behind it, is passed through.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/timesync/host_clock.hpp"
#include "sensor_rig/timesync/monotonic_stamps.hpp"
#include "sensor_rig/timesync/packet_stamper.hpp"
#include "test_instants.hpp"

namespace sensor_rig::timesync {
namespace {
using test::kHour10;
constexpr Nanos kSpan = 1'327'104;                    // VLP-16 packet span

// Issue 26 item 7: stamps held after a step back (or a raw stamp equal to the last) are 1 ns after
// the last one, never equal to it: a topic's samples keep distinct stamps (the old code held at
// the last stamp, and several samples in a row could share it).
TEST(MonotonicStamps, HeldStampsStayDistinct) {
  MonotonicStamps m(0.1);
  EXPECT_EQ(m.apply(1000 * kMs), 1000 * kMs);
  m.realtime_step(-500 * kMs);
  const Nanos a = m.apply(600 * kMs);   // the step back, taken whole: 600 + 500 ms
  const Nanos b = m.apply(600 * kMs + 1);  // 1 ns of raw time: slewed by ceil(0.1) = 1 ns, held
  const Nanos c = m.apply(600 * kMs + 1);  // the same raw stamp again
  EXPECT_EQ(a, 1100 * kMs);
  EXPECT_GT(b, a);
  EXPECT_GT(c, b);
  MonotonicStamps n(0.1);
  EXPECT_EQ(n.apply(5 * kMs), 5 * kMs);
  EXPECT_EQ(n.apply(5 * kMs), 5 * kMs + 1) << "an equal raw stamp is held 1 ns on";
}

// A step back undone by a step forward while its correction is still being slewed out: the forward
// jump of the raw stamps takes the correction back at once, so the stamps are vehicle time again
// (a -37 s step for 5 s left the LIDARs' and cameras' stamps 32.7 s, then 0.57 s, off and
// unflagged for minutes: the forward jump only slewed a tenth of itself off the correction).
TEST(MonotonicStamps, AStepBackUndoneTakesItsCorrectionBackAtOnce) {
  for (const Nanos step : {500 * kMs, 37'000 * kMs}) {
    MonotonicStamps m(0.1);
    Nanos truth = 1000 * kMs, last = m.apply(truth);
    m.realtime_step(-step);
    for (int i = 0; i < 50; ++i) {  // 5 s of the step: the raw stamps are `step` behind the truth
      truth += 100 * kMs;
      const Nanos out = m.apply(truth - step);
      EXPECT_GT(out, last);
      last = out;
    }
    EXPECT_GT(m.status().correction_ns, step - 600 * kMs) << "held, then slewed at 0.1: about 0.5 s taken off";
    m.realtime_step(step);  // undone
    for (int i = 0; i < 10; ++i) {
      truth += 100 * kMs;
      const Nanos out = m.apply(truth);
      EXPECT_GT(out, last) << "never backwards";
      EXPECT_EQ(out, truth) << step << ": vehicle time again from the first stamp after the step forward, " << i;
      last = out;
    }
    EXPECT_EQ(m.status().correction_ns, 0);
  }
  // The mapping follows the forward step a few stamps later (the detector saw it first): the same.
  MonotonicStamps m(0.1);
  Nanos truth = 1000 * kMs;
  (void)m.apply(truth);
  m.realtime_step(-2000 * kMs);
  for (int i = 0; i < 20; ++i) (void)m.apply((truth += 100 * kMs) - 2000 * kMs);
  m.realtime_step(2000 * kMs);
  (void)m.apply((truth += 100 * kMs) - 2000 * kMs);
  (void)m.apply((truth += 100 * kMs) - 2000 * kMs);
  EXPECT_EQ(m.apply(truth += 100 * kMs), truth);
  // A plain step forward with no correction standing passes as before, and a later step back is
  // still absorbed.
  MonotonicStamps f(0.1);
  (void)f.apply(1000 * kMs);
  f.realtime_step(3000 * kMs);
  EXPECT_EQ(f.apply(4100 * kMs), 4100 * kMs);
  f.realtime_step(-1000 * kMs);
  EXPECT_EQ(f.apply(3200 * kMs), 4200 * kMs) << "the step whole: vehicle time as it ran before it";
  EXPECT_EQ(f.status().backward_steps, 1u);
}

TEST(MonotonicStamps, ForwardPassesBackwardIsHeldAndSlewedOut) {
  MonotonicStamps m(0.1);
  EXPECT_EQ(m.apply(1000 * kMs), 1000 * kMs);
  EXPECT_EQ(m.apply(1100 * kMs), 1100 * kMs);
  EXPECT_EQ(m.apply(2100 * kMs), 2100 * kMs);  // forward step: at once
  EXPECT_EQ(m.status().backward_steps, 0u);
  m.realtime_step(-1000 * kMs);                // the host's CLOCK_REALTIME went back 1 s
  // The mapping follows (+0.1 s elapsed): the announced second added whole, so the 0.1 s since the
  // last stamp stays in the stamp (held at the last output, it was stamped 0.1 s early).
  EXPECT_EQ(m.apply(1200 * kMs), 2200 * kMs);
  EXPECT_EQ(m.status().backward_steps, 1u);
  EXPECT_EQ(m.status().correction_ns, 1000 * kMs);
  EXPECT_EQ(m.status().last_backward_ns, 900 * kMs);
  // Then 0.9x real rate until the correction is gone (10 s for 1 s), never backwards.
  Nanos last = 2200 * kMs, raw = 1200 * kMs;
  for (int i = 0; i < 105; ++i) {
    raw += 100 * kMs;
    const Nanos out = m.apply(raw);
    EXPECT_GT(out, last) << i;
    EXPECT_GE(out, raw);
    last = out;
  }
  EXPECT_EQ(m.status().correction_ns, 0);
  EXPECT_EQ(m.apply(raw + 100 * kMs), raw + 100 * kMs);
  EXPECT_EQ(m.status().max_correction_ns, 1000 * kMs);
  // A small backward wobble (a refit) is held, not counted as a step.
  (void)m.apply(raw + 99 * kMs);
  EXPECT_EQ(m.status().backward_steps, 1u);
  EXPECT_EQ(m.status().held, 2u);
  // A device's own glitch (no host step): 5 s ahead for one stamp, then back. Passed through, not
  // held for 50 s of slewing.
  const Nanos r = raw + 200 * kMs;
  EXPECT_EQ(m.apply(r + 5000 * kMs), r + 5000 * kMs);
  EXPECT_EQ(m.apply(r + 100 * kMs), r + 100 * kMs);
  EXPECT_EQ(m.status().device_backward, 1u);
  EXPECT_EQ(m.status().backward_steps, 1u);
  EXPECT_EQ(m.status().correction_ns, 0);
  // An announced step back the mapping never follows (a PTP-synced device stamps in its own time)
  // expires: a device jump 20 s later is not absorbed by it.
  m.realtime_step(-3000 * kMs);
  (void)m.apply(r + 200 * kMs);
  (void)m.apply(r + 20'000 * kMs);
  EXPECT_EQ(m.apply(r + 17'500 * kMs), r + 17'500 * kMs);
  EXPECT_EQ(m.status().backward_steps, 1u);
  m.reset();
  EXPECT_EQ(m.apply(5 * kMs), 5 * kMs);  // a new stream starts fresh
  EXPECT_THROW(MonotonicStamps(0.0), std::invalid_argument);
  EXPECT_THROW(MonotonicStamps(1.0), std::invalid_argument);
}

// A Velodyne (µs since the hour) or an Ouster/Hesai (absolute ns), free-running 2.5 s ahead of
// the host at +20 ppm, 754 packets/s; the host's CLOCK_REALTIME is stepped back 1 s at 5 s and
// forward 1 s at 20 s. Scans = every 75th packet's stamp (10 Hz).
void run_steps(DeviceTimeKind kind) {
  StamperConfig sc;
  sc.source = TimeSource::kSensor;
  sc.correction = Correction::kAuto;
  sc.hour.hour_source = HourSource::kHost;
  sc.packet_duration_ns = kSpan;
  PacketStamper stamper(sc);
  MonotonicStamps topic;
  RealtimeStepDetector steps;
  const Nanos period = kSec / 754;
  const Nanos mono0 = 3 * kSec;
  std::vector<Nanos> raw_scans, out_scans;
  std::vector<Nanos> truth;  // vehicle time (the host's realtime, stepped) of each scan's first firing
  Nanos realtime_offset = 0;  // injected: realtime = true time + offset
  for (int i = 0; i < 25 * 754; ++i) {
    const Nanos t = static_cast<Nanos>(i) * period;  // true elapsed time (= monotonic)
    if (i == 5 * 754) realtime_offset = -kSec;
    if (i == 20 * 754) realtime_offset = 0;
    const Nanos host = kHour10 + t;
    const Nanos device = host + 2500 * kMs + t / 50'000;  // +20 ppm
    const Nanos rx = host + realtime_offset + kSpan + 120'000 + (i % 7) * 15'000;
    DevicePacket p;
    p.kind = kind;
    p.value = kind == DeviceTimeKind::kMicrosSinceHour ? (device % (3600 * kSec)) / 1000 : device;
    p.rx_ns = rx;
    p.pps = PpsState::kAbsent;
    const Nanos stamp = stamper.stamp(p);
    if (i % 75 == 0) {
      topic.realtime_step(steps.observe(host + realtime_offset, mono0 + t));  // the driver's check
      raw_scans.push_back(stamp);
      out_scans.push_back(topic.apply(stamp));
      truth.push_back(host + realtime_offset);
    }
  }
  // Detected and counted by the host clock check: one step back, one forward.
  EXPECT_EQ(steps.steps(), 2u);
  EXPECT_NEAR(static_cast<double>(steps.last_step_ns()), 1e9, 1e6);
  EXPECT_NEAR(static_cast<double>(steps.total_step_ns()), 0.0, 2e6);
  // The mapping follows vehicle time: the raw stamps do go back (what the filter is for) ...
  bool raw_back = false;
  for (std::size_t k = 1; k < raw_scans.size(); ++k) raw_back = raw_back || raw_scans[k] < raw_scans[k - 1];
  EXPECT_TRUE(raw_back);
  // ... the published ones never do, and the step back is counted once.
  for (std::size_t k = 1; k < out_scans.size(); ++k) ASSERT_GE(out_scans[k], out_scans[k - 1]) << "scan " << k;
  EXPECT_EQ(topic.status().backward_steps, 1u);
  EXPECT_GT(topic.status().max_correction_ns, 900 * kMs);
  EXPECT_LE(topic.status().max_correction_ns, 1100 * kMs);
  // Before the step, 10 s after it (slewed out) and after the forward step: vehicle time.
  for (std::size_t k : {std::size_t{40}, std::size_t{170}, std::size_t{190}, std::size_t{230}, out_scans.size() - 1})
    EXPECT_NEAR(static_cast<double>(out_scans[k] - truth[k]), 0.0, 1e6) << "scan " << k;
  // During the slew, stamps advance at 0.9x: the step taken whole (1 s), 3 s later 0.7 s left.
  EXPECT_NEAR(static_cast<double>(out_scans[80] - truth[80]), 0.7e9, 0.05e9);
}

TEST(RealtimeSteps, VelodyneStampsStayMonotonicThroughHostClockSteps) { run_steps(DeviceTimeKind::kMicrosSinceHour); }
TEST(RealtimeSteps, AbsoluteClockStampsStayMonotonicThroughHostClockSteps) { run_steps(DeviceTimeKind::kAbsoluteNs); }

}  // namespace
}  // namespace sensor_rig::timesync
