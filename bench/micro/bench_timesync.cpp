// Micro-benchmarks of rig_timesync's per-sample paths. A synthetic device (offset, +80 ppm drift,
// 150 µs + exponential delays) keeps the mapper in its steady, locked state while measuring.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "sensor_rig/timesync/clock_mapper.hpp"
#include "sensor_rig/timesync/ptp_status.hpp"
#include "sensor_rig/timesync/stamper.hpp"
#include "sensor_rig/timesync/synchronizer.hpp"
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

// Synchronizer cost per sample: N members at 10 Hz (the mock rig's sets: 2, 3 and 10 sensors),
// ±2 ms jitter, interleaved arrivals, 5 % missing; push + pop of every set, per pushed sample.
void BM_Synchronizer_PerSample(benchmark::State& state) {
  const auto members = static_cast<std::uint32_t>(state.range(0));
  const bool bounded = state.range(1) != 0;
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<Nanos> jitter(-2'000'000, 2'000'000), delay(0, 20'000'000);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<ts::SyncSample> in;
  for (int k = 0; k < 4096; ++k) {
    for (std::uint32_t m = 0; m < members; ++m) {
      if (u(rng) < 0.05) continue;
      const Nanos t = kT0 + k * 100'000'000LL + jitter(rng);
      in.push_back({m, t, static_cast<std::uint64_t>(k), t + m * 1'000'000 + delay(rng)});
    }
  }
  std::stable_sort(in.begin(), in.end(), [](const auto& a, const auto& b) { return a.arrival_ns < b.arrival_ns; });
  ts::SyncConfig cfg;
  cfg.members = members;
  cfg.max_spread_ns = 5'000'000;
  cfg.timeout_ns = 500'000'000;
  if (bounded) cfg.min_interval_ns.assign(members, 50'000'000);
  ts::SyncSet set;
  std::size_t sets = 0;
  Nanos offset = 0;  // each pass continues after the last one in time
  std::unique_ptr<ts::Synchronizer> sync = std::make_unique<ts::Synchronizer>(cfg);
  for (auto _ : state) {
    for (auto s : in) {
      s.stamp_ns += offset;
      s.arrival_ns += offset;
      sync->push(s, s.arrival_ns);
      while (sync->pop(set)) ++sets;
    }
    offset += 4096LL * 100'000'000;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * in.size()));
  state.counters["ns_per_sample"] = benchmark::Counter(static_cast<double>(state.iterations() * in.size()),
                                                       benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["sets"] = static_cast<double>(sets);
}
BENCHMARK(BM_Synchronizer_PerSample)->ArgNames({"members", "bounded"})->Args({2, 0})->Args({2, 1})->Args({3, 1})->Args({10, 0})->Args({10, 1});

// Turning a monotonic time into vehicle time: two bare clock reads (what every such place did)
// against clock_pair_now() (common/clock.hpp: the realtime read bracketed by two monotonic ones).
void BM_ClockOffset_TwoBareReads(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(sensor_rig::vehicle_now_ns() - sensor_rig::monotonic_now_ns());
}
BENCHMARK(BM_ClockOffset_TwoBareReads);

void BM_ClockOffset_ClockPairNow(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(sensor_rig::clock_pair_now().vehicle_minus_monotonic());
}
BENCHMARK(BM_ClockOffset_ClockPairNow);

}  // namespace

BENCHMARK_MAIN();
