#pragma once
// The DDS domain of the dbw tools: `--domain N` when given (rig up passes the rig config's), else
// ROS_DOMAIN_ID when set (as ROS 2 does), else 0. With `--security DIR` the participant is a DDS
// Security one with identity `--identity NAME` of that `rig security init` directory.
#include <cstdlib>
#include <string>

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
// No security when dir is empty; else the identity's files (throws naming what is missing).
inline dds::SecurityConfig security_config(const std::string& dir, const std::string& identity) {
  return dir.empty() ? dds::SecurityConfig{} : dds::security_files(dir, identity);
}
}  // namespace sensor_rig::drivers
