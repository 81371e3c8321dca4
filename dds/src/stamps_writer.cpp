#include "sensor_rig/dds/stamps_writer.hpp"

namespace sensor_rig::dds {

dds::QosSpec stamps_qos() {
  dds::QosSpec q;
  q.depth = 64;
  return q;
}

StampsWriter::StampsWriter(const dds::Participant& p)
    : topic_(p, kStampsTopic, stamps_qos()), writer_(p, topic_, stamps_qos()) {}

void StampsWriter::write(const std::string& topic, const msg::Time& stamp, const char* frame_id,
                         std::uint64_t seq, const SampleStamps& s) {
  msg::SourceStamps m{};
  m.header.stamp = stamp;
  m.header.frame_id = const_cast<char*>(frame_id);
  m.topic = const_cast<char*>(topic.c_str());
  m.seq = seq;
  m.acquisition_ns = s.acquisition_ns;
  m.first_rx_ns = s.first_rx_ns;
  m.last_rx_ns = s.last_rx_ns;
  m.ready_ns = s.ready_ns;
  m.publish_ns = s.publish_ns;
  m.written_ns = s.written_ns;
  m.packets = s.packets;
  m.dropped = s.dropped;
  m.size_bytes = s.size_bytes;
  m.missing_packets = s.missing_packets;
  m.ecu_status_ns = s.ecu_status_ns;
  {
    std::lock_guard lock(mutex_);
    auto it = published_.find(topic);
    if (it == published_.end()) it = published_.emplace(topic, 0).first;
    m.published = ++it->second;
  }
  writer_.write(m, vehicle_now_ns());
}

}  // namespace sensor_rig::dds
