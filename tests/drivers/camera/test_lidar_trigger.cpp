// LidarTrigger without devices: its config keys, and its thread against a simulated LIDAR whose
// sweep is known exactly (scan batches every 100 ms, as the LIDAR driver delivers them): each
// trigger fires near the true crossing (loose bound: loaded host), once per turn, and stops when
// the samples stop. The mock rig's composed version (real LIDAR driver, GigE fake) is in tests/rig.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/camera/lidar_trigger.hpp"
#include "simulated_sweep.hpp"

namespace sensor_rig::drivers {
namespace {

using sweep_sim::run_until_measured;
using sweep_sim::SimulatedLidar;
using sweep_sim::Sweep;

std::string problems_of(const std::string& yaml, CameraConfig* out = nullptr) {
  auto problems = std::make_shared<config::Problems>();
  auto node = config::Node::load_string(yaml, "cams.yaml", problems);
  auto c = parse_camera_config(node);
  if (out != nullptr) *out = c;
  return problems->str();
}

TEST(LidarTriggerConfig, KeysDefaultsAndErrors) {
  CameraConfig c;
  EXPECT_EQ(problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 45, latency_us: 120}\n", &c), "");
  EXPECT_EQ(c.lidar_trigger.lidar, "front");
  EXPECT_DOUBLE_EQ(c.lidar_trigger.azimuth_deg, 45.0);
  EXPECT_DOUBLE_EQ(c.lidar_trigger.latency_us, 120.0);
  EXPECT_EQ(c.source.trigger, camera::TriggerMode::kSoftware);  // implied by lidar:
  EXPECT_TRUE(c.trigger_group.empty());

  std::string p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front}\n");
  EXPECT_NE(p.find("cams.yaml:3:"), std::string::npos) << p;
  EXPECT_NE(p.find("azimuth_deg: required with lidar"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 360}\n");
  EXPECT_NE(p.find("azimuth_deg: must be in [0, 360)"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: -1}\n");
  EXPECT_NE(p.find("azimuth_deg"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 10, mode: line}\n");
  EXPECT_NE(p.find("mode: a LIDAR trigger needs mode: software"), std::string::npos) << p;
  // A trigger group fired by the crossing (a stereo pair): rig checks that its members agree.
  EXPECT_EQ(problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {lidar: front, azimuth_deg: 10, group: stereo}\n", &c), "");
  EXPECT_EQ(c.trigger_group, "stereo");
  EXPECT_EQ(c.lidar_trigger.lidar, "front");
  p = problems_of("name: c\nbackend: v4l2\ndevice: /dev/video0\ntrigger: {lidar: front, azimuth_deg: 10}\n");
  EXPECT_NE(p.find("trigger modes need the aravis backend"), std::string::npos) << p;
  p = problems_of("name: c\ndevice: 127.0.0.3\ntrigger: {mode: software, azimuth_deg: 10}\n");
  EXPECT_NE(p.find("azimuth_deg: only with lidar"), std::string::npos) << p;
}

TEST(LidarTrigger, FiresAtTheSweepCrossingOncePerTurnAndStopsWithTheLidar) {
  LidarTriggerConfig cfg{"front", 45.0, 0.0};
  LidarTrigger trigger("cam", cfg);
  std::mutex m;
  std::vector<Nanos> fired;
  EXPECT_EQ(trigger.add([&] {
    std::lock_guard lock(m);
    fired.push_back(vehicle_now_ns());
    return true;
  }), 0u);
  const Sweep sweep{vehicle_now_ns(), -10.0, 123.0};  // 600 rpm clockwise, as a Velodyne
  SimulatedLidar lidar(sweep, trigger);
  const Nanos started = monotonic_now_ns();
  trigger.start();
  // Until 8 triggers with 3 measured (1.3 s on a quiet host), not a fixed 1.6 s: at load >= 14 the
  // sweep locks and the measurements settle later (bounded: 10 s).
  const auto enough = [&] { return trigger.figures().triggers >= 8 && trigger.figures().measured >= 3; };
  for (int i = 0; i < 1000 && !enough(); ++i) ::usleep(10'000);
  const auto running = trigger.figures();
  lidar.stop();
  // Past the stale time (0.3 s): no prediction, no trigger (polled, bounded: 5 s).
  ::usleep(400'000);
  for (int i = 0; i < 460 && trigger.figures().predicting; ++i) ::usleep(10'000);
  const auto stopped = trigger.figures();
  ::usleep(300'000);
  const auto later = trigger.figures();
  trigger.stop();

  std::vector<Nanos> errors;
  {
    std::lock_guard lock(m);
    for (Nanos f : fired) errors.push_back(std::abs(f - sweep.crossing_near(45.0, f)));
    // Never two triggers for one crossing (a turn is 100 ms).
    for (std::size_t i = 1; i < fired.size(); ++i) EXPECT_GT(fired[i] - fired[i - 1], 50'000'000) << i;
  }
  ASSERT_GE(errors.size(), 5u) << "sweep " << timesync::to_string(running.sweep.state);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 5'000'000) << "median |fire - true crossing| on this host";
  EXPECT_LT(errors.back(), 50'000'000);  // never half a turn off
  EXPECT_EQ(running.sweep.state, timesync::SweepState::kLocked);
  EXPECT_NEAR(running.sweep.rate_hz, -10.0, 0.05);
  EXPECT_GE(running.measured, 3u);  // its own figure, from the samples after each crossing
  EXPECT_LT(running.error_p50_ns, 5'000'000);
  EXPECT_FALSE(stopped.predicting);
  EXPECT_GE(stopped.prediction_lost, 1u);
  EXPECT_EQ(later.triggers, stopped.triggers);
  EXPECT_EQ(later.sweep.state, timesync::SweepState::kStale);
  // Frame stamps: the exposure start of the latest trigger before a frame.
  ASSERT_FALSE(fired.empty());
  EXPECT_NEAR(static_cast<double>(trigger.tick_before(fired.back() + 5'000'000, 0)), static_cast<double>(fired.back()), 2e6);
  EXPECT_EQ(running.members, 1u);
  dds::DriverStatus st;
  while (monotonic_now_ns() - started < 2'300'000'000) ::usleep(20'000);  // past the 2 s start-up grace
  trigger.add_status(st, 0);
  EXPECT_EQ(st.level, dds::Level::kWarn);  // the LIDAR stopped: not triggered
}

// A stereo pair on one LIDAR trigger: each crossing fires both cameras at once, once; the left
// camera's trigger takes 20 ms (a slow GVCP acknowledgement) and the right one's call does not
// wait for it. Each camera's frames carry its own trigger call (+ latency); the phase error is
// measured per camera, the spread between the calls per tick.
TEST(LidarTrigger, AGroupIsFiredTogetherAtEachCrossingWithItsOwnPhaseFigures) {
  LidarTriggerConfig cfg{"front", 0.0, 50.0};
  LidarTrigger trigger("stereo", cfg);
  std::mutex m;
  std::vector<Nanos> fired[2];
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_EQ(trigger.add([&m, &fired, i] {
      {
        std::lock_guard lock(m);
        fired[i].push_back(vehicle_now_ns());
      }
      if (i == 0) ::usleep(20'000);  // the left camera acknowledges late
      return true;
    }), i);
  ASSERT_TRUE(run_until_measured(trigger, 1, 9)) << "sweep " << timesync::to_string(trigger.figures().sweep.state);
  const auto left = trigger.figures(0);
  const auto right = trigger.figures(1);
  std::lock_guard lock(m);
  ASSERT_EQ(fired[0].size(), fired[1].size());  // one tick fires both, never one alone
  ASSERT_GE(fired[0].size(), 9u);
  EXPECT_EQ(left.triggers, fired[0].size());
  constexpr Nanos kLatency = 50'000;
  // The last ticks (the trigger keeps 16): a frame arriving 5 ms after tick k is stamped with its
  // camera's own call (+ latency); back to back, the right call would follow the left's 20 ms.
  std::size_t together = 0;
  for (std::size_t k = fired[0].size() - 8; k < fired[0].size(); ++k) {
    const Nanos frame_arrives = std::max(fired[0][k], fired[1][k]) + 30'000'000;
    for (std::size_t i = 0; i < 2; ++i) {
      const Nanos stamp = trigger.tick_before(frame_arrives, i) - kLatency;
      EXPECT_LE(stamp, fired[i][k]) << k << " camera " << i;  // its own call, just before the call ran
      EXPECT_GT(stamp, fired[i][k - 1]) << k << " camera " << i;
    }
    const Nanos stamp_left = trigger.tick_before(frame_arrives, 0);
    const Nanos stamp_right = trigger.tick_before(frame_arrives, 1);
    if (std::abs(stamp_right - stamp_left) < 10'000'000) ++together;
  }
  // Released together: the calls of nearly every tick within 10 ms (typically µs: a firing thread
  // preempted on a loaded 2-core host is what stretches one); back to back none would be (the
  // right call >= 20 ms after the left). The mock rig's spread figures are camera/README.md's.
  EXPECT_GE(together, 6u);
  // Both cameras measured against the same crossings, each with its own error (loose: loaded host).
  EXPECT_GE(left.measured, 8u);
  EXPECT_GE(right.measured, 8u);
  EXPECT_LT(left.error_p50_ns, 5'000'000);
  EXPECT_LT(right.error_p50_ns, 5'000'000);
  EXPECT_FALSE(right.from_device);  // no frames reported: the trigger call + latency
  EXPECT_EQ(right.measured, right.call_error.count);
  EXPECT_EQ(left.members, 2u);
  EXPECT_LT(left.spread_p50_ns, 10'000'000);
  EXPECT_EQ(left.spread_max_ns, right.spread_max_ns);  // the group's figure
  dds::DriverStatus st;
  trigger.add_status(st, 1);
  std::map<std::string, std::string> values(st.values.begin(), st.values.end());
  EXPECT_EQ(values["trigger_group"], "stereo");
  EXPECT_EQ(values["trigger_members"], "2");
  EXPECT_EQ(values["phase_measured"], std::to_string(right.measured));
  EXPECT_EQ(values["phase_from"], "trigger_call");
  EXPECT_EQ(values.count("trigger_spread_p99_ms"), 1u);
  EXPECT_EQ(values.count("trigger_call_error_p99_ms"), 1u);
}

// A member whose camera refuses is counted, and the tick still fires the other; none fires alone.
TEST(LidarTrigger, ARefusingMemberIsCountedAndTheOtherStillFires) {
  LidarTrigger trigger("stereo", LidarTriggerConfig{"front", 0.0, 0.0});
  std::atomic<std::uint64_t> calls[2] = {0, 0};
  std::atomic<std::uint64_t> refusals{0};
  trigger.add([&] { return ++calls[0] > 0; });
  trigger.add([&] {
    if (++calls[1] % 2 == 0) return true;
    ++refusals;
    return false;
  });
  ASSERT_TRUE(run_until_measured(trigger, 0, 6));
  const auto left = trigger.figures(0);
  const auto right = trigger.figures(1);
  EXPECT_EQ(calls[0].load(), calls[1].load());
  EXPECT_EQ(left.triggers, calls[0].load());
  EXPECT_EQ(left.refused, 0u);
  EXPECT_EQ(right.refused, refusals.load());
  EXPECT_GE(right.refused, 3u);
  EXPECT_LT(right.call_error.count, left.call_error.count);  // only its accepted triggers measured
}

// The exposure start the camera reports (its frames' device time, mapped) goes into the phase
// figure: a camera exposing 2 ms after each trigger call has ~2 ms of phase error, and its own
// delay is reported; a frame that cannot be the trigger's (more than half a turn away) is not used
// and counted.
TEST(LidarTrigger, TheCamerasReportedExposureStartIsInThePhaseFigure) {
  LidarTrigger trigger("cam", LidarTriggerConfig{"front", 0.0, 100.0});
  std::mutex m;
  std::vector<Nanos> called;
  trigger.add([&] {
    std::lock_guard lock(m);
    called.push_back(vehicle_now_ns());
    return true;
  });
  ASSERT_TRUE(run_until_measured(trigger, 0, 8));
  const auto before = trigger.figures(0);
  EXPECT_FALSE(before.from_device);
  EXPECT_EQ(before.to_exposure.count, 0u);
  constexpr Nanos kLatency = 100'000;
  constexpr Nanos kDelay = 2'000'000;  // trigger call -> exposure start, by the camera's clock
  std::vector<Nanos> ticks;  // the last 7 ticks' stamps (each call + latency)
  {
    std::lock_guard lock(m);
    for (std::size_t k = called.size() - 7; k < called.size(); ++k)
      ticks.push_back(trigger.tick_before(called[k] + 1'000'000, 0));
  }
  for (std::size_t k = 1; k < ticks.size(); ++k) trigger.exposed(0, ticks[k], ticks[k] - kLatency + kDelay);
  trigger.exposed(0, ticks.back(), ticks.back() + 1'000'000);  // told twice: the first one counts
  trigger.exposed(0, ticks.back() + 1, ticks.back());          // no such tick: ignored
  trigger.exposed(0, ticks[0], ticks[0] + 60'000'000);  // 60 ms after its call at 10 Hz: another frame
  const auto f = trigger.figures(0);
  EXPECT_TRUE(f.from_device);
  EXPECT_EQ(f.measured, 6u);
  EXPECT_EQ(f.to_exposure.count, 6u);
  EXPECT_EQ(f.to_exposure.p50_ns, kDelay);
  EXPECT_EQ(f.to_exposure.max_ns, kDelay);
  EXPECT_EQ(f.call_error.count, before.call_error.count);
  // |call - crossing + 2 ms - latency|: the 2 ms show unless the call itself was ~2 ms early.
  EXPECT_GT(f.error_max_ns, 1'000'000);
  dds::DriverStatus st;
  trigger.add_status(st, 0);
  std::map<std::string, std::string> values(st.values.begin(), st.values.end());
  EXPECT_EQ(values["phase_from"], "device_exposure");
  EXPECT_EQ(values["phase_measured"], "6");
  EXPECT_EQ(values["trigger_to_exposure_p50_ms"], "2.000");
  EXPECT_EQ(values["exposure_unmatched"], "1");
}


// Issue 27 item 1: a member whose camera does not answer (its trigger call held for 1.5 s by GVCP
// timeouts or a reopen) misses its ticks; its partner is fired at every crossing all the same, and
// stop() waits for the hung call only. Before, each tick waited for every member: the healthy
// camera of a stereo pair got a frame every few seconds.
TEST(LidarTrigger, AMemberWhoseCameraHangsDoesNotStarveItsPartner) {
  LidarTrigger trigger("stereo", LidarTriggerConfig{"front", 0.0, 0.0});
  std::atomic<std::uint64_t> calls[2] = {0, 0};
  trigger.add([&] {
    ++calls[0];
    ::usleep(1'500'000);
    return false;
  });
  trigger.add([&] { return ++calls[1] > 0; });
  const Sweep sweep{vehicle_now_ns(), -10.0, 200.0};
  SimulatedLidar lidar(sweep, trigger);
  const Nanos t_start = monotonic_now_ns();
  trigger.start();
  // Until the partner has been fired 30 times (3 s at 10 Hz once the sweep locked), on a bound made
  // for a loaded host: the starved partner of old got 3 calls in 28 s and fails it.
  while (calls[1].load() < 30 && monotonic_now_ns() - t_start < 30'000'000'000) ::usleep(10'000);
  const Nanos t_stop = monotonic_now_ns();
  trigger.stop();
  const Nanos stop_ns = monotonic_now_ns() - t_stop;
  lidar.stop();
  const auto right = trigger.figures(1);
  const auto left = trigger.figures(0);
  const std::uint64_t hung_calls = calls[0].load();
  ASSERT_GE(calls[1].load(), 30u) << "the partner starved";
  // Per 1.5 s at most the hung call and the fresh ones that replaced it (kMaxTriggerCallsLeft left
  // in flight at once), +1 for the span in flight at stop.
  const auto spans = static_cast<std::uint64_t>((t_stop - t_start) / 1'500'000'000) + 1;
  EXPECT_LE(hung_calls, (kMaxTriggerCallsLeft + 1) * spans);
  EXPECT_GE(left.calls_left, 1u);
  EXPECT_EQ(right.calls_left, 0u);
  // A partner thread woken past the shot's deadline (a loaded host) is counted refused: rare, and
  // never one a crossing per hung call as when the partner waited for it.
  EXPECT_LE(right.refused * 10, calls[1].load()) << right.refused << " refused";
  // The hung one refuses every crossing it is not in a call for.
  EXPECT_GE(left.refused + left.timed_out + hung_calls, calls[1].load());
  EXPECT_GE(left.timed_out, 1u);
  EXPECT_LT(stop_ns, 1'600'000'000);  // at most the one call in flight
}

// One call hangs 2.4 s (a trigger sent as the camera rebooted: Aravis retries it) and the camera
// answers again at once (reopened on a fresh connection): the member is fired again from the first
// shot armed kTriggerCallHungNs after the hang began, not after the hung call returns. Before, its
// firing thread sat in the call and the reopened camera got no trigger for 2.4 s.
TEST(LidarTrigger, AMemberIsFiredAgainSoonAfterOneCallHangs) {
  LidarTrigger trigger("stereo", LidarTriggerConfig{"front", 0.0, 0.0});
  struct Calls {
    std::atomic<bool> hung{false};
    std::atomic<Nanos> hung_at{0};
    std::atomic<Nanos> first_after{0};
    std::atomic<std::uint64_t> after{0};
  };
  auto c = std::make_shared<Calls>();  // shared with the left call, which returns after this test
  trigger.add([c] {
    if (!c->hung.exchange(true)) {
      c->hung_at.store(monotonic_now_ns());
      ::usleep(2'400'000);
      return false;
    }
    if (c->first_after.load() == 0) c->first_after.store(monotonic_now_ns());
    ++c->after;
    return true;
  });
  std::atomic<std::uint64_t> partner{0};
  trigger.add([&partner] { return ++partner > 0; });
  const Sweep sweep{vehicle_now_ns(), 10.0, 200.0};
  SimulatedLidar lidar(sweep, trigger);
  const Nanos t_start = monotonic_now_ns();
  trigger.start();
  // The hang begins at the first shot (once the sweep is locked); 1.5 s of shots after it, well
  // inside the hung call, on a bound made for a loaded host.
  while ((c->hung_at.load() == 0 || monotonic_now_ns() - c->hung_at.load() < 1'500'000'000) &&
         monotonic_now_ns() - t_start < 30'000'000'000)
    ::usleep(10'000);
  const std::uint64_t partner_calls = partner.load();
  trigger.stop();
  lidar.stop();
  const auto f = trigger.figures(0);
  ASSERT_NE(c->hung_at.load(), 0) << "never fired";
  ASSERT_NE(c->first_after.load(), 0) << "not fired again within 1.5 s of the hang";
  const Nanos resumed = c->first_after.load() - c->hung_at.load();
  std::printf("fired again %.0f ms after the hang began; %llu calls after it, the partner %llu\n",
              static_cast<double>(resumed) / 1e6, static_cast<unsigned long long>(c->after.load()),
              static_cast<unsigned long long>(partner_calls));
  // Left at the first shot armed past 200 ms (shots every 100 ms), fired at the one after at the latest.
  EXPECT_LT(resumed, kTriggerCallHungNs + 300'000'000);
  EXPECT_EQ(f.calls_left, 1u);
  EXPECT_GE(c->after.load() + 5, partner_calls);  // every shot since, but the 200 ms and a shot or two
}

// A camera that takes every trigger but acknowledges it after the shot's deadline (30 ms: a GVCP
// retry on a loaded host) exposes for each of them: its ticks are recorded when the call returns
// (its frames are stamped by them), never counted refused, and it is fired at every crossing
// (it is idle again when the next shot is armed). Before, each such tick was refused and lost.
TEST(LidarTrigger, ACallReturningAfterTheDeadlineStillRecordsItsTick) {
  LidarTrigger trigger("stereo", LidarTriggerConfig{"front", 0.0, 0.0});
  std::mutex m;
  std::vector<Nanos> called[2];
  std::size_t returned[2] = {0, 0};
  const auto member = [&](std::size_t i, useconds_t hold) {
    return [&, i, hold] {
      {
        std::lock_guard lock(m);
        called[i].push_back(vehicle_now_ns());
      }
      ::usleep(hold);
      std::lock_guard lock(m);
      ++returned[i];
      return true;
    };
  };
  trigger.add(member(0, 30'000));
  trigger.add(member(1, 0));
  const Sweep sweep{vehicle_now_ns(), 10.0, 200.0};
  SimulatedLidar lidar(sweep, trigger);
  const Nanos t_start = monotonic_now_ns();
  trigger.start();
  // 14 crossings fired (the checks below read the last 10), on a bound made for a loaded host.
  const auto fired = [&] {
    std::lock_guard lock(m);
    return called[1].size();
  };
  while (fired() < 14 && monotonic_now_ns() - t_start < 30'000'000'000) ::usleep(10'000);
  // Stopped between crossings: a call still in flight at stop() is left, its tick unrecorded (the
  // trigger may be gone when it returns), and the 14th crossing's slow call takes 30 ms.
  ::usleep(50'000);
  std::size_t done = 0;  // the slow calls that returned before stop()
  {
    std::lock_guard lock(m);
    done = returned[0];
  }
  trigger.stop();
  lidar.stop();
  const auto slow = trigger.figures(0);
  const auto fast = trigger.figures(1);
  std::lock_guard lock(m);
  ASSERT_GE(called[1].size(), 14u);
  EXPECT_GE(called[0].size() + 1, called[1].size());  // fired at (nearly) every crossing its partner was
  EXPECT_EQ(slow.refused, 0u);
  EXPECT_EQ(fast.refused, 0u);
  // The calls the trigger thread gave up on (its own wake-up, 25 ms after the aim, came before
  // the 30 ms call returned). A trigger thread that a loaded host wakes later sees some of them
  // return in time; the late path must still have been taken.
  EXPECT_GE(slow.timed_out, 1u);
  // Every call's tick is known (the last 10: the trigger keeps 16): a frame exposed after the call
  // maps to the tick of that call.
  ASSERT_GE(done, 10u);
  for (std::size_t k = done - 10; k < done; ++k)
    EXPECT_NEAR(static_cast<double>(trigger.tick_before(called[0][k] + 2'000'000, 0)), static_cast<double>(called[0][k]), 1e6) << k;
}

// A partner that does not answer holds the shot open for its 25 ms deadline; the healthy member's
// frame comes 10 ms after its call (the GigE fakes' exposure). Its tick must be there by then, as
// a frame is matched to the latest tick before it. Before, every such frame (a stereo camera
// beside its slow-to-open partner in rig chaos) found the tick before: 100 ms early, masked by
// the mapped exposure until a held network left the mapping in holdover, then published.
TEST(LidarTrigger, AMembersTickIsThereForItsFrameWhileAPartnerHoldsTheShot) {
  LidarTrigger trigger("stereo", LidarTriggerConfig{"front", 0.0, 0.0});
  std::mutex m;
  std::vector<std::pair<Nanos, Nanos>> healthy;  // (vehicle time of the call, monotonic return)
  trigger.add([] {
    ::usleep(200'000);  // a camera that answers nothing in time: every shot waits its deadline
    return false;
  });
  trigger.add([&] {
    const Nanos called = vehicle_now_ns();
    std::lock_guard lock(m);
    healthy.emplace_back(called, monotonic_now_ns());
    return true;
  });
  const Sweep sweep{vehicle_now_ns(), -10.0, 200.0};
  SimulatedLidar lidar(sweep, trigger);
  trigger.start();
  // Each call is checked as its frame would be: until 15 ms after it returned (the frame's
  // arrival, with a loaded host's slack, and still inside the partner's 25 ms deadline).
  std::size_t seen = 0, checked = 0, found = 0;
  const Nanos t_start = monotonic_now_ns();
  while (checked < 15 && monotonic_now_ns() - t_start < 30'000'000'000) {
    std::pair<Nanos, Nanos> call{0, 0};
    {
      std::lock_guard lock(m);
      if (healthy.size() > seen) call = healthy[seen];
    }
    if (call.first == 0) {
      ::usleep(1'000);
      continue;
    }
    ++seen;
    if (monotonic_now_ns() - call.second >= 15'000'000) continue;  // this checker came too late (a loaded host)
    bool there = false;
    while (!there && monotonic_now_ns() - call.second < 15'000'000) {
      // The frame's reference: its call + the 10 ms exposure.
      there = std::llabs(trigger.tick_before(call.first + 10'000'000, 1) - call.first) < 1'000'000;
      if (!there) ::usleep(500);
    }
    found += there ? 1 : 0;
    ++checked;
  }
  trigger.stop();
  lidar.stop();
  ASSERT_EQ(checked, 15u) << "the healthy member was not fired";
  EXPECT_EQ(found, checked) << "frames matched to the tick before their own";
}

}  // namespace
}  // namespace sensor_rig::drivers
