// A triggered camera's frame is matched to the trigger call that exposed it (LidarTrigger::
// tick_before), against the calls as they really were made: a camera that exposes sooner after the
// call than the configured latency, and whose frame is handled before the call returns (the GVCP
// acknowledgement, or a preempted firing thread, comes after the frame). Matched to the tick a
// period before, the frame is stamped a period early until its device clock maps (the stereo pair
// of sync_sets_test: an unpaired left frame, its right partner stamped 100 ms early).
#include <gtest/gtest.h>

#include <cstdlib>
#include <mutex>
#include <vector>

#include "sensor_rig/drivers/camera/lidar_trigger.hpp"
#include "simulated_sweep.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr Nanos kConfiguredLatencyNs = 500'000;

struct MatchedCall {
  Nanos called;  // vehicle time the camera saw the call
  Nanos tick;    // the tick its frame was matched to, the frame handled before the call returned
};

TEST(LidarTriggerMatching, AFrameExposedSoonerThanTheLatencyAndHandledBeforeTheCallReturnsIsItsCalls) {
  LidarTrigger trigger("cam", LidarTriggerConfig{"front", 0.0, static_cast<double>(kConfiguredLatencyNs) / 1000.0});
  std::mutex m;
  std::vector<MatchedCall> calls;
  trigger.add([&] {
    const Nanos called = vehicle_now_ns();
    // The camera exposes 200 us after the write (under the 500 us configured); its frame arrives
    // and is handled while the acknowledgement is still on its way.
    while (vehicle_now_ns() < called + 200'000) {
    }
    const Nanos tick = trigger.tick_before(vehicle_now_ns(), 0);
    {
      std::lock_guard lock(m);
      calls.push_back({called, tick});
    }
    ::usleep(2'000);  // the acknowledgement
    return true;
  });
  ASSERT_TRUE(sweep_sim::run_until_measured(trigger, 0, 8));
  std::lock_guard lock(m);
  ASSERT_GE(calls.size(), 8u);
  for (std::size_t k = 0; k < calls.size(); ++k) {
    const Nanos call_of_tick = calls[k].tick - kConfiguredLatencyNs;
    // The firing thread reads the clock just before the call: its call precedes the camera's by
    // the call's own path (microseconds; a loaded host's preemption, milliseconds), never a period.
    EXPECT_LE(call_of_tick, calls[k].called) << k;
    EXPECT_LT(calls[k].called - call_of_tick, 5'000'000) << k << ": matched " << static_cast<double>(calls[k].called - call_of_tick) * 1e-6
                                                          << " ms before its call (a period: the tick before)";
  }
}

TEST(LidarTriggerMatching, ARefusedCallIsNoTickForAFrame) {
  LidarTrigger trigger("cam", LidarTriggerConfig{"front", 0.0, 0.0});
  std::mutex m;
  std::vector<Nanos> accepted;
  std::size_t calls = 0;
  trigger.add([&] {
    const Nanos called = vehicle_now_ns();
    std::lock_guard lock(m);
    if (++calls > 5) return false;  // the camera closed: it refuses every trigger from here on
    accepted.push_back(called);
    return true;
  });
  const sweep_sim::Sweep sweep{vehicle_now_ns(), -10.0, 200.0};
  sweep_sim::SimulatedLidar lidar(sweep, trigger);
  trigger.start();
  for (int i = 0; i < 1000; ++i) {
    {
      std::lock_guard lock(m);
      if (calls >= 9) break;
    }
    ::usleep(10'000);
  }
  trigger.stop();
  lidar.stop();
  std::lock_guard lock(m);
  ASSERT_GE(calls, 9u);
  ASSERT_EQ(accepted.size(), 5u);
  // A frame arriving now (a late one) is the last accepted call's, not a refused call's.
  const Nanos tick = trigger.tick_before(vehicle_now_ns(), 0);
  EXPECT_LE(tick, accepted.back());
  EXPECT_LT(accepted.back() - tick, 5'000'000) << "matched " << static_cast<double>(accepted.back() - tick) * 1e-6 << " ms before the last accepted call";
  EXPECT_EQ(trigger.figures(0).refused, calls - 5);
}

}  // namespace
}  // namespace sensor_rig::drivers
