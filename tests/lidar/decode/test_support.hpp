#pragma once
// Helpers shared by the lidar_decode tests: capture paths, decoding a whole pcap, packet crafting.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_data.hpp"
#include <vector>

#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar::test {

inline std::string data_dir() { return sensor_rig::test::data_dir().string(); }
inline std::string velodyne_file(const std::string& name) { return data_dir() + "/lidar/velodyne/" + name; }
using sensor_rig::test::exists;
using sensor_rig::test::read_text;

// Decodes every data packet of a capture; stamps from the sensor time with the pcap hour.
inline std::vector<Scan> decode_capture(const std::string& pcap, velodyne::DecoderConfig cfg, bool with_tail = true) {
  PcapReader reader(pcap);
  velodyne::Decoder dec(std::move(cfg));
  std::vector<Scan> scans;
  while (auto r = reader.next()) {
    if (r->packet.dst_port == velodyne::kPositionPort) continue;
    const auto info = velodyne::read_packet_info(r->packet.data);
    const Nanos stamp = info ? velodyne::sensor_time_to_ns(info->sensor_time_us, r->packet.rx_ns) : r->packet.rx_ns;
    if (auto s = dec.push(r->packet, stamp)) scans.push_back(std::move(*s));
  }
  if (with_tail) {
    if (auto s = dec.flush()) scans.push_back(std::move(*s));
  }
  return scans;
}

}  // namespace sensor_rig::lidar::test
