// libFuzzer harness for the Ouster decoder (no sockets: bytes in, scans out).
// Input: byte 0 selects profile (bits 0-2), return selection (bits 3-4), emit_partial_scans (bit 5),
// intensity source (bit 6); the rest is a sequence of lidar packets of the profile's size for a
// small synthetic sensor (4 beams, 64 columns per frame, 16 per packet; a shorter tail is pushed
// as a wrong-size packet). With bit 7 set, the rest is metadata JSON for parse_metadata.
// Invariants: no crash, finite points, rings in range, packets = used + dropped.
//
// Built with -DRIG_FUZZ_CORPUS_MAIN instead, this file is the corpus generator:
//   g++ -std=c++20 -DRIG_FUZZ_CORPUS_MAIN -Ilidar/include -Icommon/include
//       tests/fuzz/fuzz_ouster.cpp; ./a.out tests/fuzz/corpus/ouster
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>

#include "scan_checks.hpp"
#include "sensor_rig/lidar/mock/ouster_packet_builder.hpp"

namespace ot = sensor_rig::lidar::ouster::builder;
using sensor_rig::lidar::ouster::Profile;

constexpr int kPixels = 4;
constexpr int kColumns = 64;

#ifndef RIG_FUZZ_CORPUS_MAIN
#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

const ouster::SensorMetadata& metadata_for(Profile p) {
  static const auto kAll = [] {
    std::vector<ouster::SensorMetadata> v;
    for (const auto& spec : ouster::all_profiles())
      v.push_back(ouster::parse_metadata(ot::nested_metadata(std::string(spec.name), kPixels, kColumns), "fuzz.json"));
    return v;
  }();
  return kAll[static_cast<std::size_t>(p)];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t mode = data[0];
  const auto bytes = std::as_bytes(std::span(data + 1, size - 1));
  if ((mode & 0x80) != 0) {
    try {
      (void)ouster::parse_metadata(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), "fuzz.json");
    } catch (const ouster::MetadataError&) {
    }
    return 0;
  }
  ouster::DecoderConfig cfg;
  cfg.metadata = metadata_for(static_cast<Profile>(mode & 7));
  cfg.returns = static_cast<ouster::ReturnSelection>(((mode >> 3) & 3) % 3);
  cfg.emit_partial_scans = (mode & 0x20) != 0;
  cfg.intensity = (mode & 0x40) != 0 ? ouster::IntensitySource::kReflectivity : ouster::IntensitySource::kSignal;
  ouster::Decoder dec(cfg);
  const std::size_t n = dec.layout().packet_size;
  Nanos t = 1'000'000'000;
  for (std::size_t off = 0; off < bytes.size(); off += n) {
    const auto pkt = bytes.subspan(off, std::min(n, bytes.size() - off));
    if (auto ts = dec.first_column_time(pkt)) t = static_cast<Nanos>(*ts & 0x3FFFFFFFFFFFFFFFULL);
    if (auto s = dec.push(PacketView{pkt, t, 7502}, t)) fuzz::check_scan(*s, kPixels);
  }
  if (auto s = dec.flush()) fuzz::check_scan(*s, kPixels);
  const auto& st = dec.stats();
  fuzz::check_counters(st);
  return 0;
}

#else  // corpus generator

#include <filesystem>
#include <fstream>
#include <vector>

namespace {

std::vector<std::uint8_t> frame_packet(Profile prof, std::uint32_t frame, std::size_t k, unsigned seed) {
  std::vector<ot::Column> cols(16);
  for (std::size_t c = 0; c < 16; ++c) {
    cols[c].measurement_id = static_cast<std::uint16_t>(k * 16 + c);
    cols[c].timestamp_ns = 1'000'000'000ULL + (frame * kColumns + k * 16 + c) * 1'562'500ULL;
    cols[c].valid = (seed + c) % 7 != 0;
    for (int r = 0; r < kPixels; ++r) {
      seed = seed * 1103515245U + 12345U;
      ot::Pixel p;
      p.first = {(seed >> 8) % 40000U * 8U, static_cast<std::uint8_t>(seed), static_cast<std::uint16_t>(seed >> 4)};
      p.second = {p.first.range_mm + 800, static_cast<std::uint8_t>(seed >> 3), 10};
      p.near_ir = static_cast<std::uint16_t>(seed >> 16);
      cols[c].pixels.push_back(p);
    }
  }
  return ot::encode_packet(prof, kPixels, frame, cols, 7654321);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  // One frame and the first packet of the next, per profile; dual profiles with every selection.
  for (int prof = 0; prof < 8; ++prof) {
    const auto p = static_cast<Profile>(prof);
    std::vector<std::vector<std::uint8_t>> pk;
    for (std::size_t k = 0; k < 4; ++k) pk.push_back(frame_packet(p, 7, k, static_cast<unsigned>(prof * 10 + k)));
    pk.push_back(frame_packet(p, 8, 0, 99));
    sensor_rig::lidar::fuzz::write_corpus_file(dir, "profile" + std::to_string(prof), static_cast<std::uint8_t>(prof | ((prof % 3) << 3)), pk);
  }
  // Joined mid-frame, partial scans emitted; a truncated tail.
  auto tail = frame_packet(Profile::kLegacy, 2, 3, 5);
  tail.resize(tail.size() / 2);
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "legacy_partial_truncated", 0x20,
        {frame_packet(Profile::kLegacy, 1, 2, 1), frame_packet(Profile::kLegacy, 1, 3, 2), tail});
  std::ofstream(dir / "metadata_nested", std::ios::binary)
      << '\x80' << ot::nested_metadata("RNG19_RFL8_SIG16_NIR16_DUAL", 4, 64);
  std::ofstream(dir / "metadata_flat", std::ios::binary)
      << '\x80'
      << R"({"lidar_mode": "512x20", "beam_altitude_angles": [1, 0], "beam_azimuth_angles": [0, 0],
"lidar_origin_to_beam_origin_mm": 12.1, "lidar_to_sensor_transform": [-1,0,0,0,0,-1,0,0,0,0,1,36.18,0,0,0,1],
"data_format": {"pixels_per_column": 2, "columns_per_packet": 16, "columns_per_frame": 512,
"column_window": [500, 10], "pixel_shift_by_row": [0, 8]}})";
  return 0;
}

#endif
