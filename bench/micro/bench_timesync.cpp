// Micro-benchmarks of rig_timesync's per-sample paths. A synthetic device (offset, +80 ppm drift,
// 150 µs + exponential delays) keeps the mapper in its steady, locked state while measuring.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sensor_rig/timesync/clock_mapper.hpp"
#include "sensor_rig/timesync/ptp_status.hpp"
#include "sensor_rig/timesync/stamper.hpp"
#include "sensor_rig/timesync/top_of_hour.hpp"

namespace ts = sensor_rig::timesync;
using sensor_rig::Nanos;

namespace {

constexpr Nanos kT0 = 1'795'255'200'000'000'000;  // 2026-11-21 10:00 UTC
constexpr double kDrift = 80e-6;

// Feeds (device, host) pairs of a drifting device at `period` with random delays.
class Feed {
 public:
  explicit Feed(Nanos period) : period_(period), delays_(1 << 14) {
    std::mt19937_64 rng(1);
    std::exponential_distribution<double> e(1.0 / 200'000.0);
    for (auto& d : delays_) d = 150'000 + static_cast<Nanos>(e(rng));
  }
  Nanos device() const { return 42'000'000'000 + t_ + static_cast<Nanos>(static_cast<double>(t_) * kDrift); }
  Nanos host() const { return kT0 + t_ + delays_[i_ & (delays_.size() - 1)]; }
  Nanos vehicle() const { return kT0 + t_; }
  void next() {
    t_ += period_;
    ++i_;
  }

 private:
  Nanos period_;
  Nanos t_ = 0;
  std::size_t i_ = 0;
  std::vector<Nanos> delays_;
};

void warm(ts::ClockMapper& m, Feed& f, int n) {
  for (int i = 0; i < n; ++i, f.next()) m.observe(f.device(), f.host());
}

// LIDAR rate (VLP-16, 754 Hz): most samples only update a bucket; a refit every 100 ms.
void BM_ClockMapper_Observe_754Hz(benchmark::State& state) {
  ts::ClockMapper m;
  Feed f(1'327'104);
  warm(m, f, 20'000);
  for (auto _ : state) {
    benchmark::DoNotOptimize(m.observe(f.device(), f.host()));
    f.next();
  }
  state.counters["locked"] = m.state() == ts::SyncState::kLocked ? 1 : 0;
}
BENCHMARK(BM_ClockMapper_Observe_754Hz);

// Camera rate (10 Hz): every sample opens a bucket and refits the 256-bucket window (worst case).
void BM_ClockMapper_Observe_10Hz(benchmark::State& state) {
  ts::ClockMapper m;
  Feed f(100'000'000);
  warm(m, f, 400);
  for (auto _ : state) {
    benchmark::DoNotOptimize(m.observe(f.device(), f.host()));
    f.next();
  }
  state.counters["locked"] = m.state() == ts::SyncState::kLocked ? 1 : 0;
}
BENCHMARK(BM_ClockMapper_Observe_10Hz);

void BM_ClockMapper_ToVehicle(benchmark::State& state) {
  ts::ClockMapper m;
  Feed f(1'327'104);
  warm(m, f, 20'000);
  Nanos d = f.device();
  for (auto _ : state) {
    benchmark::DoNotOptimize(m.to_vehicle(d));
    d += 1'327'104;
  }
}
BENCHMARK(BM_ClockMapper_ToVehicle);

void BM_TopOfHour_Resolve(benchmark::State& state) {
  ts::TopOfHourClock c;
  Nanos t = kT0;
  for (auto _ : state) {
    const auto us = static_cast<std::uint32_t>(t % ts::kHourNs / 1000);
    benchmark::DoNotOptimize(c.resolve(us, t + 700'000, t / 1'000'000'000 * 1'000'000'000));
    t += 1'327'104;
  }
}
BENCHMARK(BM_TopOfHour_Resolve);

// The driver's per-packet call: free-running sensor, hour from the host, mapped to vehicle time.
void BM_Stamper_SensorMapped(benchmark::State& state) {
  ts::StamperConfig cfg;
  cfg.packet_duration_ns = 1'327'104;
  cfg.host_latency_ns = 150'000;
  ts::Stamper s(cfg);
  Feed f(1'327'104);
  auto packet = [&] {
    const Nanos d = f.device();
    return ts::PacketTime{static_cast<std::uint32_t>(d % ts::kHourNs / 1000), f.host() + 1'327'104,
                          std::nullopt, ts::PpsState::kAbsent};
  };
  for (int i = 0; i < 20'000; ++i, f.next()) s.stamp(packet());
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.stamp(packet()));
    f.next();
  }
}
BENCHMARK(BM_Stamper_SensorMapped);

void BM_Stamper_Gps(benchmark::State& state) {
  ts::StamperConfig cfg;
  cfg.packet_duration_ns = 1'327'104;
  ts::Stamper s(cfg);
  Nanos t = kT0;
  for (auto _ : state) {
    const ts::PacketTime p{static_cast<std::uint32_t>(t % ts::kHourNs / 1000), t + 1'500'000,
                           t / 1'000'000'000 * 1'000'000'000, ts::PpsState::kLocked};
    benchmark::DoNotOptimize(s.stamp(p));
    t += 1'327'104;
  }
}
BENCHMARK(BM_Stamper_Gps);

void BM_PmcParse(benchmark::State& state) {
  const std::string text =
      "sending: GET TIME_STATUS_NP\n"
      "\t90e2ba.fffe.20c7f8-0 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP \n"
      "\t\tmaster_offset              -37\n"
      "\t\tingress_time               1795255200034372012\n"
      "\t\tcumulativeScaledRateOffset +0.000012345\n"
      "\t\tscaledLastGmPhaseChange    0\n"
      "\t\tgmTimeBaseIndicator        0\n"
      "\t\tlastGmPhaseChange          0x0000'0000000000000000.0000\n"
      "\t\tgmPresent                  true\n"
      "\t\tgmIdentity                 0050c2.fffe.d0d000\n";
  for (auto _ : state) benchmark::DoNotOptimize(ts::parse_pmc_time_status(text));
}
BENCHMARK(BM_PmcParse);

}  // namespace

BENCHMARK_MAIN();
