// The camera stamp path per frame (drivers' FrameClock::stamp): a free-running GigE camera whose
// ticks are mapped, and a software-triggered one (its tick, then its mapped exposure), as a stream
// of frames at 10 Hz with a 20 ppm device clock and 0-400 us of arrival jitter. One stamp() per
// iteration, the stream carried over iterations (the mapper and the monotonic filter see a
// continuous stream, as on the car). BENCHMARKS.md "Camera stamp path".
#include <benchmark/benchmark.h>

#include <cstdint>

#include "sensor_rig/drivers/camera/frame_clock.hpp"

namespace {

using sensor_rig::Nanos;
namespace cam = sensor_rig::camera;
namespace drv = sensor_rig::drivers;

constexpr Nanos kPeriod = 100'000'000;   // 10 Hz
constexpr Nanos kExposure = 5'000'000;   // 5 ms
constexpr Nanos kStart = 1'790'000'000'000'000'000;

// Frame i: true exposure start, device ticks at 20 ppm fast, first packet after exposure + jitter.
cam::FrameMeta frame(std::uint64_t i) {
  cam::FrameMeta m;
  m.seq = i;
  const Nanos truth = kStart + static_cast<Nanos>(i) * kPeriod;
  m.device_ns = 5'000'000'000 + static_cast<Nanos>(i) * (kPeriod + kPeriod / 50'000);
  m.domain = cam::TimeDomain::kDeviceTicks;
  const Nanos jitter = static_cast<Nanos>((i * 7919u) % 400u) * 1'000;
  m.first_rx_ns = truth + kExposure + 200'000 + jitter;
  m.complete_ns = m.first_rx_ns + 2'000'000;
  m.packets = 300;
  return m;
}

void BM_FrameClock_FreeRunning(benchmark::State& state) {
  drv::FrameClock clock(kExposure);
  std::uint64_t i = 0;
  for (auto _ : state) {
    const auto s = clock.stamp(frame(i++));
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_FrameClock_FreeRunning);

void BM_FrameClock_Triggered(benchmark::State& state) {
  drv::FrameClock clock(kExposure);
  std::uint64_t i = 0;
  for (auto _ : state) {
    const auto m = frame(i);
    const Nanos tick = kStart + static_cast<Nanos>(i++) * kPeriod - 50'000;  // trigger call before the exposure
    const auto s = clock.stamp(m, tick);
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_FrameClock_Triggered);

}  // namespace

BENCHMARK_MAIN();
