#pragma once
// QoS as a plain struct (from config) turned into a dds_qos_t. Defaults: reliable, keep-last 1,
// volatile — the latest sample matters for sensor data and control, and late joiners should not
// receive stale scans or commands.
#include <dds/dds.h>

#include <cstdint>
#include <memory>
#include <string>

namespace sensor_rig::config {
class Node;
}

namespace sensor_rig::dds {

struct QosSpec {
  enum class Reliability { kReliable, kBestEffort } reliability = Reliability::kReliable;
  enum class Durability { kVolatile, kTransientLocal } durability = Durability::kVolatile;
  int depth = 1;                       // keep-last depth; 0 = keep-all
  std::int64_t max_blocking_ms = 100;  // reliable writer: block at most this long when full
  std::int64_t deadline_ms = 0;        // 0 = none
  std::int64_t lifespan_ms = 0;        // 0 = infinite

  // Reads `reliability`, `durability`, `depth`, `max_blocking_ms`, `deadline_ms`, `lifespan_ms`.
  static QosSpec from_config(const config::Node& node, QosSpec defaults);
  static QosSpec sensor_data() { return {}; }
};

struct QosDeleter {
  void operator()(dds_qos_t* q) const noexcept { dds_delete_qos(q); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

QosPtr make_qos(const QosSpec& spec);
std::string to_string(const QosSpec& spec);

}  // namespace sensor_rig::dds
