// libFuzzer harness for the Hesai decoder (no sockets: bytes in, scans out).
// Input: byte 0 selects model / return selection / cut angle / partial scans; bit 7 set means the
// rest is calibration text (angle or Firetime CSV). Otherwise the rest is a sequence of packets of
// the model's size (a shorter tail is pushed as a wrong-size packet), stamped from their own UTC
// time like the CLI does. Invariants: no crash, finite points, rings in range, counters add up.
//
// Built with -DRIG_FUZZ_CORPUS_MAIN instead, this file is the corpus generator:
//   g++ -std=c++20 -DRIG_FUZZ_CORPUS_MAIN -Ilidar/include -Icommon/include
//       tests/fuzz/fuzz_hesai.cpp && ./a.out tests/fuzz/corpus/hesai
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>

#include "scan_checks.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"

#ifndef RIG_FUZZ_CORPUS_MAIN
#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/hesai/decoder.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t mode = data[0];
  const auto model = (mode & 1) != 0 ? hesai::Model::kPandarXT32 : hesai::Model::kPandar40P;
  const auto bytes = std::as_bytes(std::span(data + 1, size - 1));
  if ((mode & 0x80) != 0) {
    const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    try {
      if (hesai::is_firetime_csv(text)) {
        (void)hesai::parse_firetime_csv(text, "fuzz.csv", model);
      } else {
        hesai::DecoderConfig cfg;
        cfg.model = model;
        cfg.calibration = hesai::parse_angle_csv(text, "fuzz.csv", model);
        hesai::Decoder d(cfg);  // any accepted calibration must build a decoder
      }
    } catch (const DecoderConfigError&) {
    }
    return 0;
  }
  hesai::DecoderConfig cfg;
  cfg.model = model;
  cfg.returns = static_cast<hesai::ReturnSelection>(((mode >> 1) & 3) % 3);
  cfg.cut_angle_deg = ((mode >> 3) & 3) * 90.0 + 0.5;
  cfg.emit_partial_scans = (mode & 0x20) != 0;
  // A decoder per input: without this, two full-scan buffers (1.7-3.5 MB) were mapped and
  // unmapped per input, 53 % of the CPU in system time. Small buffers grow like any vector.
  cfg.first_scan_reserve_points = 64;
  hesai::Decoder dec(cfg);
  const int channels = hesai::model_info(model).channels;
  const std::size_t psize = hesai::model_info(model).packet_size;
  Nanos t = 1'000'000'000;
  for (std::size_t off = 0; off < bytes.size(); off += psize) {
    const auto pkt = bytes.subspan(off, std::min(psize, bytes.size() - off));
    if (auto info = hesai::read_packet_info(pkt, model); info && info->tail_time_ns) {
      t = *info->tail_time_ns + dec.first_firing_offset_ns(info->returns);  // may jump anywhere
    }
    if (auto s = dec.push(PacketView{pkt, t, hesai::kDataPort}, t)) fuzz::check_scan(*s, channels);
  }
  if (auto s = dec.flush()) fuzz::check_scan(*s, channels);
  const auto& st = dec.stats();
  std::uint64_t by_status = 0;
  for (auto n : st.by_status) by_status += n;
  if (by_status != st.packets) std::abort();
  fuzz::check_counters(st);
  return 0;
}

#else  // corpus generator

#include <filesystem>
#include <fstream>
#include <vector>

#include "sensor_rig/lidar/mock/hesai_packet_builder.hpp"

namespace {

namespace h = sensor_rig::lidar::hesai;

std::vector<std::byte> packet(h::builder::Kind kind, std::uint8_t return_mode, int az0, int step, unsigned seed,
                              std::uint32_t us) {
  h::builder::PacketSpec s;
  s.kind = kind;
  s.return_mode = return_mode;
  s.azimuth0 = az0;
  s.step = step;
  s.us = us;
  s.unit = [&seed](int, int) -> h::builder::RawUnit {
    seed = seed * 1103515245U + 12345U;
    const auto d = static_cast<std::uint16_t>((seed >> 8) % 30000U);
    return {static_cast<std::uint16_t>(d < 500 ? 0 : d), static_cast<std::uint8_t>(seed >> 24)};
  };
  return h::builder::build_packet(s);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  using h::builder::Kind;
  // mode: bit 0 model (0 Pandar40P, 1 PandarXT32), bits 1-2 returns, bits 3-4 cut, bit 5 partial.
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "p40_strongest_cut", 0x20,
        {packet(Kind::k40P, 0x37, 35800, 20, 1, 100), packet(Kind::k40P, 0x37, 0, 20, 2, 656),
         packet(Kind::k40P, 0x37, 200, 20, 3, 1212), packet(Kind::k40P, 0x37, 400, 20, 4, 1768)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "p40_dual", 0x04,
        {packet(Kind::k40P, 0x39, 9000, 20, 5, 100), packet(Kind::k40P, 0x39, 9100, 20, 6, 378)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "xt32_dual_first_last", 0x01 | 0x04 | 0x08,
        {packet(Kind::kXT32, 0x3B, 8950, 18, 7, 999'800), packet(Kind::kXT32, 0x3B, 9022, 18, 8, 200)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "xt32_last", 0x01 | 0x02, {packet(Kind::kXT32, 0x38, 35900, 18, 9, 5)});
  auto short_pkt = packet(Kind::k40P, 0x37, 0, 20, 10, 0);
  short_pkt.resize(700);
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "wrong_size", 0, {short_pkt});
  std::ofstream(dir / "calibration_40p", std::ios::binary) << '\x80' << "Laser id,Elevation,Azimuth\n1,14.794,-1.042\n"
                                                           << "2,10.944,-1.042\n3,x,0\n";
  std::ofstream(dir / "firetime_xt32", std::ios::binary) << '\x81' << "\xEF\xBB\xBF" "Channel,fire time(us)\n1,6\n2,7.512\n";
  return 0;
}

#endif
