#include "qos_profiles.hpp"

#include <yaml-cpp/yaml.h>

#include <sstream>

namespace sensor_rig::rig {
namespace {

// rmw's "infinite" duration as rosbag2 writes it.
constexpr const char* kInfinite = "    sec: 9223372036\n    nsec: 854775807\n";

}  // namespace

std::string offered_qos_profiles(const std::vector<dds::QosSpec>& writers) {
  std::ostringstream o;
  for (const auto& q : writers) {
    // rmw enums: history 1 keep_last / 2 keep_all; reliability 1 reliable / 2 best_effort;
    // durability 1 transient_local / 2 volatile; liveliness 1 automatic.
    o << "- history: " << (q.depth > 0 ? 1 : 2) << "\n"
      << "  depth: " << (q.depth > 0 ? q.depth : 0) << "\n"
      << "  reliability: " << (q.reliability == dds::QosSpec::Reliability::kReliable ? 1 : 2) << "\n"
      << "  durability: " << (q.durability == dds::QosSpec::Durability::kTransientLocal ? 1 : 2) << "\n"
      << "  deadline:\n" << kInfinite << "  lifespan:\n" << kInfinite << "  liveliness: 1\n"
      << "  liveliness_lease_duration:\n" << kInfinite << "  avoid_ros_namespace_conventions: false\n";
  }
  return o.str();
}

ParsedQos parse_offered_qos_profiles(const std::string& yaml) {
  ParsedQos r;
  try {
    const YAML::Node root = YAML::Load(yaml);
    if (!root.IsSequence() || root.size() == 0) {
      r.why_not = "no profile in offered_qos_profiles";
      return r;
    }
    const YAML::Node p = root[0];
    const auto text = [&](const char* key) { return p[key] ? p[key].as<std::string>() : std::string(); };
    const std::string history = text("history"), reliability = text("reliability"), durability = text("durability");
    r.qos.depth = p["depth"] ? p["depth"].as<int>() : 1;
    if (history == "2" || history == "keep_all") r.qos.depth = 0;
    else if (r.qos.depth <= 0) r.qos.depth = 1;  // keep_last 0 / unknown / system default: as rmw, depth 1
    r.qos.reliability = reliability == "2" || reliability == "best_effort" ? dds::QosSpec::Reliability::kBestEffort
                                                                            : dds::QosSpec::Reliability::kReliable;
    r.qos.durability = durability == "1" || durability == "transient_local" ? dds::QosSpec::Durability::kTransientLocal
                                                                            : dds::QosSpec::Durability::kVolatile;
    r.ok = true;
  } catch (const YAML::Exception& e) {
    r.why_not = std::string("offered_qos_profiles is not YAML: ") + e.what();
  }
  return r;
}

}  // namespace sensor_rig::rig
