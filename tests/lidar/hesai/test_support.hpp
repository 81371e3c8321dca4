#pragma once
// Helpers shared by the lidar_hesai tests: data paths, one-packet decoding, error capture.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "test_data.hpp"
#include <vector>

#include "sensor_rig/lidar/mock/hesai_packet_builder.hpp"
#include "sensor_rig/lidar/hesai/decoder.hpp"

namespace sensor_rig::lidar::hesai::test {

using namespace builder;  // NOLINT(google-build-using-namespace): tests name the builder as test::

inline std::string data_dir() { return sensor_rig::test::data_dir().string(); }
inline std::string hesai_file(const std::string& name) { return data_dir() + "/lidar/hesai/" + name; }
using sensor_rig::test::exists;
using sensor_rig::test::read_text;

// Decodes one packet and returns the points of the (partial) scan it started.
inline std::vector<PointXYZIRT> decode_one(DecoderConfig cfg, const std::vector<std::byte>& pkt,
                                           Nanos stamp = 1'000'000'000) {
  cfg.emit_partial_scans = true;
  Decoder d(std::move(cfg));
  (void)d.push(PacketView{pkt, stamp, kDataPort}, stamp);
  auto s = d.flush();
  return s ? s->points : std::vector<PointXYZIRT>{};
}

// The message of the DecoderConfigError `f` throws ("" if it does not throw).
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const DecoderConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace sensor_rig::lidar::hesai::test
