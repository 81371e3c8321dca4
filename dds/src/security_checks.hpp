#pragma once
// Private to dds/: checks of an identity's files before Cyclone reads them (security_checks.cpp).
#include <string>

namespace sensor_rig::dds {
// Throws std::runtime_error when group or others have any access to the key file (its mode, `chmod 600`).
void check_private_key_mode(const std::string& path, const std::string& identity);
}  // namespace sensor_rig::dds
