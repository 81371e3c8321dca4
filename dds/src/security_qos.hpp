#pragma once
// Private to dds/: the participant QoS properties of a SecurityConfig.
#include <dds/dds.h>

#include "sensor_rig/dds/security.hpp"

namespace sensor_rig::dds {
// Sets Cyclone's dds.sec.* properties (plugins, identity, permissions); throws when a plugin is missing.
void set_security_properties(dds_qos_t* qos, const SecurityConfig& c);
}  // namespace sensor_rig::dds
