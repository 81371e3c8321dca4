#include "sensor_rig/dds/diagnostics.hpp"

namespace sensor_rig::dds {

DiagnosticsPublisher::DiagnosticsPublisher(const dds::Participant& p) : topic_(p, "/diagnostics"), writer_(p, topic_) {}

void DiagnosticsPublisher::publish(const std::vector<DriverStatus>& statuses) {
  // Views into `statuses`: the C message points at strings owned by the caller for the write.
  std::vector<msg::DiagnosticStatus> items(statuses.size());
  std::vector<std::vector<msg::KeyValue>> kvs(statuses.size());
  for (std::size_t i = 0; i < statuses.size(); ++i) {
    const auto& s = statuses[i];
    for (const auto& [k, v] : s.values)
      kvs[i].push_back(msg::KeyValue{const_cast<char*>(k.c_str()), const_cast<char*>(v.c_str())});
    auto& d = items[i];
    d.level = static_cast<std::uint8_t>(s.level);
    d.name = const_cast<char*>(s.name.c_str());
    d.message = const_cast<char*>(s.message.c_str());
    d.hardware_id = const_cast<char*>(s.hardware_id.c_str());
    d.values._buffer = kvs[i].data();
    d.values._length = d.values._maximum = static_cast<std::uint32_t>(kvs[i].size());
    d.values._release = false;
  }
  msg::DiagnosticArray a{};
  const Nanos now = vehicle_now_ns();
  a.header.stamp = msg::to_time(now);
  a.header.frame_id = const_cast<char*>("");
  a.status._buffer = items.data();
  a.status._length = a.status._maximum = static_cast<std::uint32_t>(items.size());
  a.status._release = false;
  writer_.write(a, now);
}

}  // namespace sensor_rig::dds
