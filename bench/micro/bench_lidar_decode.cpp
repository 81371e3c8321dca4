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
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

struct Packet {
  std::vector<std::byte> bytes;
  Nanos stamp;
};

using bench::data_dir;
using bench::read_text;

std::vector<Packet> load_capture(const std::string& path) {
  std::vector<Packet> out;
  if (!std::filesystem::exists(path)) return out;
  PcapReader r(path);
  while (auto rec = r.next()) {
    if (rec->packet.data.size() != velodyne::kDataPacketSize) continue;
    // A packet without readable time (damaged capture) is still decoded (and counted as a drop):
    // stamped with its record time, as the decode CLI does.
    const auto info = velodyne::read_packet_info(rec->packet.data);
    const Nanos stamp = info ? velodyne::sensor_time_to_ns(info->sensor_time_us, rec->packet.rx_ns) : rec->packet.rx_ns;
    out.push_back({std::vector<std::byte>(rec->packet.data.begin(), rec->packet.data.end()), stamp});
  }
  return out;
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
  std::uint64_t points = 0;
  std::uint64_t pushed = 0;
  // Each pass continues the timeline so the decoder sees one long, steady stream.
  const Nanos pass_ns = packets.back().stamp - packets.front().stamp + (packets[1].stamp - packets[0].stamp);
  Nanos offset = 0;
  for (auto _ : state) {
    for (const auto& p : packets) {
      auto scan = dec.push(PacketView{p.bytes, p.stamp + offset, velodyne::kDataPort}, p.stamp + offset);
      if (scan) {
        points += scan->points.size();
        benchmark::DoNotOptimize(scan->points.data());
        if (recycle) dec.recycle(std::move(scan->points));  // as a publisher returning the loan
      }
    }
    pushed += packets.size();
    offset += pass_ns;
  }
  if (dec.stats().time_jumps != 0) state.SkipWithError("time jumps in the packet stream");
  state.counters["ns_per_packet"] =
      benchmark::Counter(static_cast<double>(pushed) * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["points_per_s"] = benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
  state.SetItemsProcessed(static_cast<std::int64_t>(pushed));
}

void register_all() {
  struct Src {
    velodyne::Model model;
    const char* file;
  };
  for (const Src s : {Src{velodyne::Model::kVLP16, "vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap"},
                      Src{velodyne::Model::kHDL32E, "hdl32e_veloview_monterey-first-100-packets.pcap"},
                      Src{velodyne::Model::kVLP32C, nullptr}}) {
    const std::string name(velodyne::model_info(s.model).name);
    auto capture = s.file ? load_capture(data_dir() + "/lidar/velodyne/" + s.file) : std::vector<Packet>{};
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

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
