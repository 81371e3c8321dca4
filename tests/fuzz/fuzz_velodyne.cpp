// libFuzzer harness for the Velodyne decoder (no sockets: bytes in, scans out).
// Input: byte 0 selects model / return selection / cut angle / target; the rest is a sequence of
// packets (1206-byte chunks; a shorter tail is pushed as a wrong-size packet). Calibration text has
// its own harness, fuzz_velodyne_calibration: the two were one until the calibration inputs (parsed
// by yaml-cpp, ~800 inputs/s under ASan) made 92 % of the corpus and starved the decoder.
// Invariants: no crash, finite points, rings in range, counters consistent.
//
// Built with -DRIG_FUZZ_CORPUS_MAIN instead, this file is the corpus generator:
//   g++ -std=c++20 -DRIG_FUZZ_CORPUS_MAIN -Ilidar/include -Icommon/include tests/fuzz/fuzz_velodyne.cpp
//   ./a.out tests/fuzz/corpus/velodyne
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "scan_checks.hpp"
#include "sensor_rig/lidar/velodyne/packet.hpp"

#ifndef RIG_FUZZ_CORPUS_MAIN
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace {

using namespace sensor_rig;
using namespace sensor_rig::lidar;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t mode = data[0];
  const auto bytes = std::as_bytes(std::span(data + 1, size - 1));
  velodyne::DecoderConfig cfg;
  cfg.model = static_cast<velodyne::Model>(mode % 3);
  cfg.returns = static_cast<velodyne::ReturnSelection>((mode / 3) % 3);
  cfg.cut_angle_deg = ((mode >> 4) & 3) * 90.0;
  cfg.emit_partial_scans = (mode & 0x40) != 0;
  cfg.interpolation = (mode & 0x08) != 0 ? velodyne::AzimuthInterpolation::kPerLaser
                                         : velodyne::AzimuthInterpolation::kPerSequence;
  cfg.first_scan_reserve_points = 64;  // a decoder per input: no full-scan buffer (0.7-3.3 MB) each
  velodyne::Decoder dec(cfg);
  const int lasers = velodyne::model_info(cfg.model).lasers;
  Nanos t = 1'000'000'000;
  for (std::size_t off = 0; off < bytes.size(); off += velodyne::kDataPacketSize) {
    const auto pkt = bytes.subspan(off, std::min(velodyne::kDataPacketSize, bytes.size() - off));
    if (auto info = velodyne::read_packet_info(pkt)) {
      // Packet time as a driver would take it: from the sensor clock (may jump anywhere).
      t = velodyne::sensor_time_to_ns(info->sensor_time_us, t);
    }
    if (auto s = dec.push(PacketView{pkt, t, velodyne::kDataPort}, t)) fuzz::check_scan(*s, lasers);
    (void)to_string(dec.last_status());
  }
  if (auto s = dec.flush()) fuzz::check_scan(*s, lasers);
  fuzz::check_counters(dec.stats());
  return 0;
}

#else  // corpus generator

#include <filesystem>
#include <fstream>
#include <vector>

namespace {

namespace v = sensor_rig::lidar::velodyne;

std::vector<std::uint8_t> packet(v::ProductId pid, v::ReturnMode mode, int az0, int step, std::uint32_t us,
                                 unsigned seed) {
  v::RawDataPacket p{};
  const bool dual = mode == v::ReturnMode::kDual;
  for (std::size_t b = 0; b < v::kBlocksPerPacket; ++b) {
    v::put_le16(p.blocks[b].flag, v::kBlockFlagUpper);
    const int k = dual ? static_cast<int>(b / 2) : static_cast<int>(b);
    v::put_le16(p.blocks[b].azimuth, static_cast<std::uint16_t>((az0 + k * step) % 36000));
    for (std::size_t c = 0; c < v::kChannelsPerBlock; ++c) {
      seed = seed * 1103515245U + 12345U;
      const auto d = static_cast<std::uint16_t>((seed >> 8) % 30000U);
      v::put_le16(p.blocks[b].channels[c].distance, d < 500 ? 0 : d);
      p.blocks[b].channels[c].intensity = static_cast<std::uint8_t>(seed >> 24);
    }
  }
  v::put_le32(p.timestamp, us);
  p.return_mode = static_cast<std::uint8_t>(mode);
  p.product_id = static_cast<std::uint8_t>(pid);
  std::vector<std::uint8_t> out(sizeof p);
  std::memcpy(out.data(), &p, sizeof p);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  using v::ProductId;
  using v::ReturnMode;
  // mode: model = mode % 3 (0 VLP-16, 1 VLP-32C, 2 HDL-32E), returns = (mode / 3) % 3.
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "vlp16_strongest_wrap", 0x40,
        {packet(ProductId::kVLP16, ReturnMode::kStrongest, 35500, 40, 1000, 1),
         packet(ProductId::kVLP16, ReturnMode::kStrongest, 35980, 40, 2327, 2),
         packet(ProductId::kVLP16, ReturnMode::kStrongest, 460, 40, 3654, 3)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "vlp16_dual", 6,
        {packet(ProductId::kVLP16, ReturnMode::kDual, 100, 40, 1000, 4),
         packet(ProductId::kVLP16, ReturnMode::kDual, 340, 40, 2327, 5)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "vlp32c_last_cut90", 0x10 | 4,
        {packet(ProductId::kVLP32C, ReturnMode::kLast, 8900, 20, 5000, 6),
         packet(ProductId::kVLP32C, ReturnMode::kLast, 9140, 20, 5664, 7)});
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "hdl32e_strongest", 2 | 0x08,
        {packet(ProductId::kHDL32E, ReturnMode::kStrongest, 35900, 20, 3'599'999'000U, 8),
         packet(ProductId::kHDL32E, ReturnMode::kStrongest, 140, 20, 553, 9)});
  auto short_pkt = packet(ProductId::kVLP16, ReturnMode::kStrongest, 0, 40, 0, 10);
  short_pkt.resize(700);
  sensor_rig::lidar::fuzz::write_corpus_file(dir, "wrong_size", 0, {short_pkt});
  return 0;
}

#endif
