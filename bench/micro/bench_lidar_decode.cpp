// Decode throughput per model on one core: every data packet of a capture is pushed through the
// decoder (xyz, intensity, ring, return type, per-point time, straight into Scan::points; the
// emitted scans are handed off and freed as a publisher would). Captures come from
// $RIG_TEST_DATA/lidar/velodyne (default ../shared/data); without them, synthetic packets of the
// same model are used and the benchmark name says so.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "bench_data.hpp"
#include "decode_passes.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

using bench::data_dir;
using Packet = bench::StampedPacket;

std::vector<Packet> load_velodyne_capture(const std::string& path) {
  return bench::load_capture(path, [](const PcapRecord& rec) -> std::optional<Nanos> {
    if (rec.packet.data.size() != velodyne::kDataPacketSize) return std::nullopt;
    // A packet without readable time (damaged capture) is still decoded (and counted as a drop):
    // stamped with its record time, as the decode CLI does.
    const auto info = velodyne::read_packet_info(rec.packet.data);
    return info ? velodyne::sensor_time_to_ns(info->sensor_time_us, rec.packet.rx_ns) : rec.packet.rx_ns;
  });
}

// One revolution and a half of synthetic packets: random ranges, ~5 % no return.
std::vector<Packet> synthetic(velodyne::Model m) {
  const auto& info = velodyne::model_info(m);
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> dist(0, 20000);
  std::vector<Packet> out;
  const int step = static_cast<int>(info.block_us * 1e-6 * 600.0 / 60.0 * 36000.0);  // 600 rpm
  int az = 0;
  Nanos t = 1'000'000'000'000;
  for (int k = 0; k < 36000 / (12 * step) * 3 / 2; ++k) {
    velodyne::RawDataPacket p{};
    for (auto& b : p.blocks) {
      velodyne::put_le16(b.flag, velodyne::kBlockFlagUpper);
      velodyne::put_le16(b.azimuth, static_cast<std::uint16_t>(az));
      az = (az + step) % 36000;
      for (auto& c : b.channels) {
        const int d = dist(rng);
        velodyne::put_le16(c.distance, static_cast<std::uint16_t>(d < 1000 ? 0 : d));
        c.intensity = static_cast<std::uint8_t>(d & 0xFF);
      }
    }
    p.return_mode = static_cast<std::uint8_t>(velodyne::ReturnMode::kStrongest);
    p.product_id = static_cast<std::uint8_t>(info.product_id);
    Packet pk{std::vector<std::byte>(sizeof p), t};
    std::memcpy(pk.bytes.data(), &p, sizeof p);
    out.push_back(std::move(pk));
    t += static_cast<Nanos>(info.block_us * 12000.0);
  }
  return out;
}

void run(benchmark::State& state, velodyne::Model m, const std::vector<Packet>& packets, bool recycle,
         velodyne::AzimuthInterpolation interpolation = velodyne::AzimuthInterpolation::kPerLaser) {
  if (packets.size() < 2) {
    state.SkipWithError("no packets");
    return;
  }
  velodyne::DecoderConfig cfg;
  cfg.model = m;
  cfg.interpolation = interpolation;
  velodyne::Decoder dec(cfg);
  bench::decode_passes(state, dec, packets, velodyne::kDataPort, bench::pass_duration(packets), recycle);
  if (dec.stats().time_jumps != 0) state.SkipWithError("time jumps in the packet stream");
}

}  // namespace

void sensor_rig::bench::register_benchmarks() {
  struct Src {
    velodyne::Model model;
    const char* file;
  };
  for (const Src s : {Src{velodyne::Model::kVLP16, "vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap"},
                      Src{velodyne::Model::kHDL32E, "hdl32e_veloview_monterey-first-100-packets.pcap"},
                      Src{velodyne::Model::kVLP32C, nullptr}}) {
    const std::string name(velodyne::model_info(s.model).name);
    auto capture = s.file ? load_velodyne_capture(data_dir() + "/lidar/velodyne/" + s.file) : std::vector<Packet>{};
    const bool real = !capture.empty();
    auto packets = std::make_shared<std::vector<Packet>>(real ? std::move(capture) : synthetic(s.model));
    for (const bool recycle : {false, true}) {
      benchmark::RegisterBenchmark(
          ("decode/" + name + (real ? "/capture" : "/synthetic") + (recycle ? "/recycled_buffers" : "/new_buffers")).c_str(),
          [m = s.model, packets, recycle](benchmark::State& st) { run(st, m, *packets, recycle); })
          ->Unit(benchmark::kMillisecond);
    }
    // VeloView's per-sequence azimuth (the default before per-laser): one table lookup per sequence.
    benchmark::RegisterBenchmark(
        ("decode/" + name + (real ? "/capture" : "/synthetic") + "/recycled_buffers/per_sequence").c_str(),
        [m = s.model, packets](benchmark::State& st) {
          run(st, m, *packets, true, velodyne::AzimuthInterpolation::kPerSequence);
        })
        ->Unit(benchmark::kMillisecond);
  }
}

