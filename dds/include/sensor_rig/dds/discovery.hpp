#pragma once
// What writers exist on the domain: Cyclone's built-in publication topic (DCPSPublication), joined
// with the participant topic for the writer's host. A monitor subscribes to what it discovers here.
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/qos.hpp"

namespace sensor_rig::dds {

struct Publication {
  std::string topic;             // DDS topic name ("rt/..." for ROS topics)
  std::string type;              // registered type name ("sensor_msgs::msg::dds_::PointCloud2_")
  std::string writer_guid;       // 32 hex digits
  std::string participant_guid;  // 32 hex digits
  std::string host;              // the writer's host (its participant's __Hostname), "" when not yet known
  QosSpec::Reliability reliability = QosSpec::Reliability::kReliable;
  QosSpec::Durability durability = QosSpec::Durability::kVolatile;
  int depth = 1;                 // the writer's keep-last depth; 0 = keep-all
  bool alive = true;             // false: the writer went away (only writer_guid is set then)
};

class DiscoveryReader {
 public:
  explicit DiscoveryReader(const Participant& p);  // throws DdsError

  // Publications seen since the last call (new writers, and writers that went away). Never throws.
  std::vector<Publication> take(std::size_t max = 64);
  // For WaitSet::attach_reader: wakes when a publication is seen.
  [[nodiscard]] dds_entity_t handle() const noexcept { return publications_.handle(); }

 private:
  void take_participants();

  Entity participants_;
  Entity publications_;
  std::map<std::string, std::string> hosts_;  // participant GUID -> host name
};

// 16 GUID bytes as 32 lowercase hex digits.
std::string guid_to_hex(const dds_guid_t& guid);

}  // namespace sensor_rig::dds
