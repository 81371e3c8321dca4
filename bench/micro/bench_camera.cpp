// Camera image work on one core at 1920x1200 (the car's cameras): bilinear debayer (the fast path
// vs the per-pixel definition it is tested against), JPEG (libturbojpeg, quality 90, 4:2:0) of the
// colour image, the worker's whole job (debayer + JPEG) and the capture thread's only cost, the
// copy into the worker's queue. items/s = pixels/s (MPix/s = items_per_second / 1e6).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "sensor_rig/camera/debayer.hpp"
#include "sensor_rig/camera/jpeg.hpp"

namespace cam = sensor_rig::camera;

namespace {

constexpr std::uint32_t kW = 1920;
constexpr std::uint32_t kH = 1200;

// A scene with smooth shading, edges and sensor noise, through an RGGB filter (JPEG speed depends
// on content: pure noise or flat colour would flatter or punish it).
const std::vector<std::uint8_t>& bayer_scene() {
  static const std::vector<std::uint8_t> kRaw = [] {
    std::vector<std::uint8_t> r(static_cast<std::size_t>(kW) * kH);
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 3.0);
    for (std::uint32_t y = 0; y < kH; ++y)
      for (std::uint32_t x = 0; x < kW; ++x) {
        const double shade = 60.0 + 120.0 * x / kW + 40.0 * std::sin(y * 0.01);
        const double edge = ((x / 64 + y / 64) % 2 == 0) ? 30.0 : 0.0;
        const int site = (y % 2) * 2 + (x % 2);  // R, G, G, B
        const double gain = site == 0 ? 1.1 : site == 3 ? 0.7 : 1.0;
        const double v = (shade + edge) * gain + noise(rng);
        r[static_cast<std::size_t>(y) * kW + x] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
      }
    return r;
  }();
  return kRaw;
}

cam::ImageIn input() { return {bayer_scene(), kW, kH, kW, cam::PixelFormat::kBayerRG8}; }

void BM_DebayerReference(benchmark::State& state) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(kW) * kH * 3);
  for (auto _ : state) {
    benchmark::DoNotOptimize(cam::debayer_reference(input(), cam::ColorOrder::kBgr, out));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kW * kH);
}
BENCHMARK(BM_DebayerReference)->Unit(benchmark::kMillisecond);

void BM_Debayer(benchmark::State& state) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(kW) * kH * 3);
  for (auto _ : state) {
    benchmark::DoNotOptimize(cam::debayer(input(), cam::ColorOrder::kBgr, out));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kW * kH);
}
BENCHMARK(BM_Debayer)->Unit(benchmark::kMillisecond);

void BM_Jpeg(benchmark::State& state) {
  std::vector<std::uint8_t> bgr(static_cast<std::size_t>(kW) * kH * 3);
  (void)cam::debayer(input(), cam::ColorOrder::kBgr, bgr);
  cam::JpegEncoder enc(static_cast<int>(state.range(0)));
  std::size_t bytes = 0;
  for (auto _ : state) {
    if (enc.encode({bgr, kW, kH, kW * 3, cam::PixelFormat::kBgr8}) != cam::JpegStatus::kOk) state.SkipWithError("encode");
    bytes = enc.jpeg().size();
  }
  state.SetItemsProcessed(state.iterations() * kW * kH);
  state.counters["jpeg_kB"] = static_cast<double>(bytes) / 1024.0;
}
BENCHMARK(BM_Jpeg)->Arg(90)->Arg(75)->Unit(benchmark::kMillisecond);

// The worker's job per frame for image_color + compressed, with either debayer.
template <bool Fast>
void BM_WorkerJob(benchmark::State& state) {
  std::vector<std::uint8_t> bgr(static_cast<std::size_t>(kW) * kH * 3);
  cam::JpegEncoder enc(90);
  for (auto _ : state) {
    if (Fast)
      (void)cam::debayer(input(), cam::ColorOrder::kBgr, bgr);
    else
      (void)cam::debayer_reference(input(), cam::ColorOrder::kBgr, bgr);
    if (enc.encode({bgr, kW, kH, kW * 3, cam::PixelFormat::kBgr8}) != cam::JpegStatus::kOk) state.SkipWithError("encode");
  }
  state.SetItemsProcessed(state.iterations() * kW * kH);
}
BENCHMARK(BM_WorkerJob<false>)->Name("BM_WorkerJob/reference_debayer+jpeg90")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WorkerJob<true>)->Name("BM_WorkerJob/fast_debayer+jpeg90")->Unit(benchmark::kMillisecond);

// The capture thread's share: one copy of the raw frame into the worker's buffer.
void BM_QueueCopy(benchmark::State& state) {
  std::vector<std::uint8_t> dst(bayer_scene().size());
  for (auto _ : state) {
    std::memcpy(dst.data(), bayer_scene().data(), dst.size());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kW * kH);
}
BENCHMARK(BM_QueueCopy)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
