#pragma once
// The DDS domain of the dbw tools: `--domain N` when given (rig up passes the rig config's), else
// ROS_DOMAIN_ID when set (as ROS 2 does), else 0.
#include <cstdlib>

#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::drivers {
inline dds::DomainConfig domain_config(int domain = -1) {
  dds::DomainConfig c;
  if (domain >= 0) {
    c.domain_id = static_cast<dds_domainid_t>(domain);
  } else if (const char* id = std::getenv("ROS_DOMAIN_ID"); id != nullptr && *id != '\0') {
    c.domain_id = static_cast<dds_domainid_t>(std::strtoul(id, nullptr, 10));
  }
  return c;
}
}  // namespace sensor_rig::drivers
