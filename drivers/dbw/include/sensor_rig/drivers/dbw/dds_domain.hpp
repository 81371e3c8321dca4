#pragma once
// The DDS domain of the dbw tools: ROS_DOMAIN_ID when set (as ROS 2 does), else 0.
#include <cstdlib>

#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::drivers {
inline dds::DomainConfig domain_config() {
  dds::DomainConfig c;
  if (const char* id = std::getenv("ROS_DOMAIN_ID"); id != nullptr && *id != '\0') {
    c.domain_id = static_cast<dds_domainid_t>(std::strtoul(id, nullptr, 10));
  }
  return c;
}
}  // namespace sensor_rig::drivers
