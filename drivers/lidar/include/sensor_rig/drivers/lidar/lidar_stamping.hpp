#pragma once
// The LIDAR side of timesync's one stamping policy: a decoder's SensorTime as timesync's
// DevicePacket, and the PacketStamper config a LIDAR config (or `rig lidar decode`) asks for.
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/timesync/packet_stamper.hpp"

namespace sensor_rig::drivers {

inline timesync::DevicePacket device_packet(lidar::SensorTime t, Nanos rx_ns) noexcept {
  timesync::DevicePacket p;
  p.kind = t.kind == lidar::SensorTime::Kind::kMicrosSinceHour ? timesync::DeviceTimeKind::kMicrosSinceHour
           : t.kind == lidar::SensorTime::Kind::kAbsoluteNs    ? timesync::DeviceTimeKind::kAbsoluteNs
                                                                : timesync::DeviceTimeKind::kNone;
  p.value = t.value;
  p.rx_ns = rx_ns;
  return p;
}

inline timesync::StamperConfig stamper_config(timesync::TimeSource source, timesync::HourSource hour,
                                              timesync::Correction correction, Nanos packet_span_ns) {
  timesync::StamperConfig sc;
  sc.source = source;
  sc.packet_duration_ns = packet_span_ns;
  sc.hour.hour_source = hour;
  sc.correction = correction;
  return sc;
}

}  // namespace sensor_rig::drivers
