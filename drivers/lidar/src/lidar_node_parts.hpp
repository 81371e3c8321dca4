#pragma once
// What a LIDAR node is built from, made from its config (lidar_driver.cpp composes them): the
// decoder, the stamper's config, the packet sources (UDP socket or AF_PACKET ring), the pcap
// recorder, and the QoS of its side topics and raw channel. Private to drivers/lidar.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/lidar/recorder_thread.hpp"
#include "sensor_rig/lidar/ring_source.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/lidar/udp_source.hpp"
#include "sensor_rig/timesync/stamper.hpp"

namespace sensor_rig::drivers::lidar_parts {

std::unique_ptr<lidar::ScanDecoder> make_driver_decoder(const LidarConfig& c);
timesync::StamperConfig lidar_stamper_config(const LidarConfig& c, Nanos packet_span_ns);
std::unique_ptr<lidar::RecorderThread> make_recorder(const LidarConfig& c);
std::uint32_t ipv4_of(const std::string& host);
bool model_vendor_is(const LidarConfig& c, std::string_view vendor);
std::unique_ptr<lidar::UdpSource> make_udp_source(const LidarConfig& c);
bool has_second_port(const LidarConfig& c);
std::unique_ptr<lidar::RingSource> make_ring_source(const LidarConfig& c);
dds::QosSpec side_qos();
dds::QosSpec raw_qos();

}  // namespace sensor_rig::drivers::lidar_parts
