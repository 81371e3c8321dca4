#include "lidar_node_parts.hpp"

#include <arpa/inet.h>

#include <stdexcept>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/drivers/lidar/lidar_stamping.hpp"

namespace sensor_rig::drivers::lidar_parts {

std::unique_ptr<lidar::ScanDecoder> make_driver_decoder(const LidarConfig& c) {
  try {
    return lidar::make_decoder(decoder_options(c));
  } catch (const lidar::DecoderConfigError& e) {
    throw std::runtime_error("lidar " + c.name + ": " + e.what());
  }
}

timesync::StamperConfig lidar_stamper_config(const LidarConfig& c, Nanos packet_span_ns) {
  return stamper_config(c.time_source, c.hour_source, c.clock_correction, packet_span_ns);
}

std::unique_ptr<lidar::RecorderThread> make_recorder(const LidarConfig& c) {
  if (c.record.directory.empty()) return nullptr;
  lidar::PcapRecorderConfig r;
  r.directory = c.record.directory;
  r.prefix = c.name;
  r.max_file_bytes = static_cast<std::uint64_t>(c.record.max_file_mb * 1024.0 * 1024.0);
  r.max_file_ns = static_cast<Nanos>(c.record.max_file_s * 1e9);
  r.max_files = static_cast<std::size_t>(c.record.max_files);
  const auto queue_bytes = static_cast<std::size_t>(c.record.queue_mb * 1024.0 * 1024.0);
  return std::make_unique<lidar::RecorderThread>(std::make_unique<lidar::PcapRecorder>(r), queue_bytes);
}

std::uint32_t ipv4_of(const std::string& host) {
  in_addr a{};
  return ::inet_pton(AF_INET, host.c_str(), &a) == 1 ? ntohl(a.s_addr) : 0;
}

bool model_vendor_is(const LidarConfig& c, std::string_view vendor) {
  const auto* m = lidar::find_model(c.model);
  return m != nullptr && m->vendor == vendor;
}

// The data port's source as the config asks: a UDP socket, or the packet ring on an interface.
// No SO_REUSEADDR: a second driver on the same port must fail, not silently share packets.
std::unique_ptr<lidar::UdpSource> make_udp_source(const LidarConfig& c) {
  if (c.source != LidarSource::kUdp) return nullptr;
  return std::make_unique<lidar::UdpSource>(
      lidar::UdpSourceConfig{{c.host, static_cast<std::uint16_t>(c.port)}, c.receive_buffer_bytes, 64, false});
}

// Velodyne position packets and Ouster IMU packets; Hesai's GPS port is not read.
bool has_second_port(const LidarConfig& c) {
  return c.position_port != 0 && (model_vendor_is(c, "velodyne") || model_vendor_is(c, "ouster"));
}

// The ring takes both of the sensor's ports (one filter, one ring, demultiplexed by port).
std::unique_ptr<lidar::RingSource> make_ring_source(const LidarConfig& c) {
  if (c.source != LidarSource::kPacket) return nullptr;
  lidar::RingSourceConfig r;
  r.interface = c.interface;
  r.port = static_cast<std::uint16_t>(c.port);
  r.second_port = has_second_port(c) ? static_cast<std::uint16_t>(c.position_port) : 0;
  r.sensor_host = c.sensor_address.empty() ? 0 : ipv4_of(c.sensor_address);  // the driver also locks
  r.retire_timeout_ms = c.ring_retire_ms;
  try {
    return std::make_unique<lidar::RingSource>(r);
  } catch (const std::exception& e) {  // unknown interface, no CAP_NET_RAW: say which LIDAR
    throw std::runtime_error("lidar " + c.name + ": " + e.what());
  }
}

// Side topics (IMU 100 Hz, GPS fix ~1 Hz): reliable, keep-last 10, volatile.
dds::QosSpec side_qos() {
  dds::QosSpec q;
  q.depth = 10;
  return q;
}

// Raw packets: reliable keep-last 64 (one sample per receive call): a recorder that lags a little
// loses nothing, and the driver's write never blocks.
dds::QosSpec raw_qos() {
  dds::QosSpec q;
  q.depth = 64;
  return q;
}

}  // namespace sensor_rig::drivers::lidar_parts
