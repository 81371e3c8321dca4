// Hesai decode throughput on one core: every data packet of the Pandar40P capture (dual return,
// nebula's calibration) pushed through the decoder, scans handed off as a publisher would; the
// PandarXT32 on synthetic packets (no capture in the shared data). Counters: ns_per_packet,
// points_per_s. Capture from $RIG_TEST_DATA/lidar/hesai (default ../shared/data).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_data.hpp"
#include "decode_passes.hpp"
#include "sensor_rig/lidar/mock/hesai_packet_builder.hpp"
#include "sensor_rig/lidar/hesai/decoder.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

using bench::data_dir;
using bench::read_text;
using Packet = bench::StampedPacket;

std::vector<Packet> load_hesai_capture(const std::string& path, hesai::Model m) {
  return bench::load_capture(path, [m](const PcapRecord& rec) -> std::optional<Nanos> {
    const auto info = hesai::read_packet_info(rec.packet.data, m);
    if (!info || !info->tail_time_ns) return std::nullopt;
    return *info->tail_time_ns + hesai::first_firing_offset_ns(m, info->returns);
  });
}

// Two turns of single-return XT32 packets at 10 Hz (so passes continue seamlessly): random ranges, ~5 % no return.
std::vector<Packet> synthetic_xt32() {
  std::mt19937 rng(42);
  std::vector<Packet> out;
  Nanos t = 1'000'000'000'000;
  for (int k = 0; k < 500; ++k) {
    hesai::builder::PacketSpec s;
    s.kind = hesai::builder::Kind::kXT32;
    s.azimuth0 = (k * 8 * 18) % hesai::kAzimuthCount;
    s.step = 18;
    s.unit = [&rng](int, int) -> hesai::builder::RawUnit {
      const auto d = static_cast<std::uint16_t>(rng() % 20000);
      return {static_cast<std::uint16_t>(d < 1000 ? 0 : d), static_cast<std::uint8_t>(d)};
    };
    out.push_back({hesai::builder::build_packet(s), t});
    t += 8 * 50'000;
  }
  return out;
}

void run(benchmark::State& state, const hesai::DecoderConfig& cfg, const std::vector<Packet>& packets) {
  if (packets.size() < 2) {
    state.SkipWithError("no packets");
    return;
  }
  hesai::Decoder dec(cfg);
  bench::decode_passes(state, dec, packets, hesai::kDataPort, bench::pass_duration(packets), /*recycle=*/true);
  if (dec.stats().dropped() != 0) state.SkipWithError("packets dropped");
}

}  // namespace

void sensor_rig::bench::register_benchmarks() {
  const std::string dir = data_dir() + "/lidar/hesai/";
  auto capture = std::make_shared<std::vector<Packet>>(
      load_hesai_capture(dir + "pandar40p_nebula_1673400149412331409.pcap", hesai::Model::kPandar40P));
  for (const auto r : {hesai::ReturnSelection::kDual, hesai::ReturnSelection::kStrongest}) {
    hesai::DecoderConfig cfg;
    cfg.model = hesai::Model::kPandar40P;
    cfg.returns = r;
    if (std::filesystem::exists(dir + "nebula_Pandar40P.csv")) {
      cfg.calibration =
          hesai::parse_angle_csv(read_text(dir + "nebula_Pandar40P.csv"), "nebula_Pandar40P.csv", cfg.model);
    }
    const std::string name = std::string("decode/Pandar40P/capture/") + (r == hesai::ReturnSelection::kDual ? "dual" : "strongest");
    benchmark::RegisterBenchmark(name.c_str(), [cfg, capture](benchmark::State& st) { run(st, cfg, *capture); })
        ->Unit(benchmark::kMillisecond);
  }
  auto xt = std::make_shared<std::vector<Packet>>(synthetic_xt32());
  hesai::DecoderConfig xcfg;
  xcfg.model = hesai::Model::kPandarXT32;
  benchmark::RegisterBenchmark("decode/PandarXT32/synthetic/single",
                               [xcfg, xt](benchmark::State& st) { run(st, xcfg, *xt); })
      ->Unit(benchmark::kMillisecond);
}

