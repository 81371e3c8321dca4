// Ouster decode throughput on one core: every lidar packet pushed through the decoder (column
// headers, xyz from the LUT, intensity, ring, return type, per-point time, into Scan::points).
//  - decode/OS-1-32-G/LEGACY/capture: the shared OS-1-32-G capture (one 1024x10 frame, 64
//    packets), replayed as a continuing stream;
//  - decode/OS-2-128/<profile>/synthetic: the shared OS-2-128 metadata (FW 2.3.0) with synthetic
//    packets (random ranges, ~5 % no return) for the single- and dual-return profiles.
// Data from $RIG_TEST_DATA/lidar/ouster (default ../shared/data); absent files skip with a message.
// RIG_BENCH_OUSTER_EXPORT=DIR also writes, per stream, the packets (u32 little-endian length +
// bytes), the metadata and the first scan's x y z (float), for the ouster-sdk peer benchmark
// (scripts/bench_ouster_peer.sh) to time and check the same packets.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bench_data.hpp"
#include "decode_passes.hpp"
#include "sensor_rig/lidar/mock/ouster_packet_builder.hpp"
#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;
namespace os = sensor_rig::lidar::ouster;

using bench::data_dir;
using bench::read_text;

struct Stream {
  std::string meta_json;
  os::SensorMetadata meta;
  std::vector<std::vector<std::byte>> packets;
  std::string error;
};

std::shared_ptr<Stream> load_ouster_capture() {
  auto s = std::make_shared<Stream>();
  const std::string dir = data_dir() + "/lidar/ouster/";
  const std::string pcap = dir + "OS-1-32-G_v2.1.1_1024x10.pcap";
  const std::string meta = dir + "OS-1-32-G_v2.1.1_1024x10.json";
  if (!std::filesystem::exists(pcap) || !std::filesystem::exists(meta)) {
    s->error = "capture not found under " + dir;
    return s;
  }
  s->meta_json = read_text(meta);
  s->meta = os::parse_metadata(s->meta_json, meta);
  PcapReader r(pcap);
  while (auto rec = r.next())
    if (rec->packet.dst_port == s->meta.udp_port_lidar)
      s->packets.emplace_back(rec->packet.data.begin(), rec->packet.data.end());
  return s;
}

std::shared_ptr<Stream> synthetic_os2(const std::string& profile) {
  auto s = std::make_shared<Stream>();
  const std::string meta = data_dir() + "/lidar/ouster/OS-2-128-U1_v2.3.0_1024x10.json";
  if (!std::filesystem::exists(meta)) {
    s->error = "metadata not found: " + meta;
    return s;
  }
  auto j = nlohmann::json::parse(read_text(meta));
  j["data_format"]["udp_profile_lidar"] = profile;
  s->meta_json = j.dump();
  s->meta = os::parse_metadata(s->meta_json, meta);
  const auto prof = s->meta.profile;
  std::mt19937 rng(42);
  std::uniform_int_distribution<std::uint32_t> dist(0, 60000);
  const std::size_t h = static_cast<std::size_t>(s->meta.pixels_per_column);
  for (std::size_t k = 0; k < 64; ++k) {
    std::vector<os::builder::Column> cols(16);
    for (std::size_t c = 0; c < 16; ++c) {
      cols[c].measurement_id = static_cast<std::uint16_t>(k * 16 + c);
      cols[c].timestamp_ns = 1'000'000'000'000ULL + (k * 16 + c) * 97'656ULL;
      cols[c].pixels.resize(h);
      for (auto& px : cols[c].pixels) {
        const std::uint32_t d = dist(rng);
        px.first = {d < 3000 ? 0U : d * 8, static_cast<std::uint8_t>(d), static_cast<std::uint16_t>(d)};
        px.second = {d < 30000 ? 0U : d * 8 + 800, static_cast<std::uint8_t>(d >> 2), static_cast<std::uint16_t>(d >> 2)};
      }
    }
    const auto b = os::builder::encode_packet(prof, h, 1, cols, s->meta.init_id);
    const auto* p = reinterpret_cast<const std::byte*>(b.data());
    s->packets.emplace_back(p, p + b.size());
  }
  return s;
}

void run(benchmark::State& state, const Stream& s, os::ReturnSelection sel, bool recycle) {
  if (!s.error.empty() || s.packets.empty()) {
    state.SkipWithError(s.error.empty() ? "no packets" : s.error.c_str());
    return;
  }
  os::DecoderConfig cfg;
  cfg.metadata = s.meta;
  cfg.returns = sel;
  os::Decoder dec(cfg);
  // Stamped by the first column's sensor time, as the node's sensor-time stamping does.
  std::vector<bench::StampedPacket> packets;
  for (const auto& p : s.packets) packets.push_back({p, static_cast<Nanos>(dec.first_column_time(p).value_or(0))});
  const Nanos pass_ns = 100'000'000;  // one frame at 10 Hz
  bench::decode_passes(state, dec, packets, s.meta.udp_port_lidar, pass_ns, recycle);
  if (dec.stats().time_jumps != 0 || dec.stats().dropped() != 0) state.SkipWithError("time jumps or drops");
}

template <class T>
void write_bytes(std::ofstream& f, const T* data, std::size_t n) {
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(n * sizeof(T)));
}

// The stream's packets and metadata, and the x y z of the first scan our decoder emits from them.
void export_stream(const std::string& dir, const std::string& name, const Stream& s) {
  if (!s.error.empty() || s.packets.empty()) return;
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/" + name + ".json", std::ios::binary) << s.meta_json;
  std::ofstream packets(dir + "/" + name + ".packets", std::ios::binary);
  os::DecoderConfig cfg;
  cfg.metadata = s.meta;
  os::Decoder dec(cfg);
  std::optional<Scan> first;
  for (const auto& p : s.packets) {
    const auto n = static_cast<std::uint32_t>(p.size());
    write_bytes(packets, &n, 1);
    write_bytes(packets, p.data(), p.size());
    const auto stamp = static_cast<Nanos>(dec.first_column_time(p).value_or(0));
    auto scan = dec.push(PacketView{p, stamp, s.meta.udp_port_lidar}, stamp);
    if (scan && !first) first = std::move(scan);
  }
  std::vector<float> xyz;
  if (first)
    for (const auto& pt : first->points) xyz.insert(xyz.end(), {pt.x, pt.y, pt.z});
  std::ofstream out(dir + "/" + name + ".ours.xyz", std::ios::binary);
  write_bytes(out, xyz.data(), xyz.size());
}

}  // namespace

void sensor_rig::bench::register_benchmarks() {
  const auto capture = load_ouster_capture();
  for (const bool recycle : {false, true}) {
    benchmark::RegisterBenchmark(
        (std::string("decode/OS-1-32-G/LEGACY/capture") + (recycle ? "/recycled_buffers" : "/new_buffers")).c_str(),
        [capture, recycle](benchmark::State& st) { run(st, *capture, os::ReturnSelection::kStrongest, recycle); })
        ->Unit(benchmark::kMicrosecond);
  }
  const auto single = synthetic_os2("RNG19_RFL8_SIG16_NIR16");
  benchmark::RegisterBenchmark("decode/OS-2-128/RNG19_RFL8_SIG16_NIR16/synthetic/recycled_buffers",
                               [single](benchmark::State& st) { run(st, *single, os::ReturnSelection::kStrongest, true); })
      ->Unit(benchmark::kMicrosecond);
  const auto dual = synthetic_os2("RNG19_RFL8_SIG16_NIR16_DUAL");
  benchmark::RegisterBenchmark("decode/OS-2-128/RNG19_RFL8_SIG16_NIR16_DUAL/synthetic/dual/recycled_buffers",
                               [dual](benchmark::State& st) { run(st, *dual, os::ReturnSelection::kDual, true); })
      ->Unit(benchmark::kMicrosecond);
  if (const char* dir = std::getenv("RIG_BENCH_OUSTER_EXPORT"); dir != nullptr && *dir != '\0') {
    export_stream(dir, "OS-1-32-G_LEGACY_capture", *capture);
    export_stream(dir, "OS-2-128_RNG19_RFL8_SIG16_NIR16_synthetic", *single);
  }
}

