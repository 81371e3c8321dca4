#pragma once
// Default paths of the drive-by-wire tools (the bridge, the mock ECU, `rig up`).
#include <string>

namespace sensor_rig::dbw {

// The reference protocol mapping: $RIG_SOURCE_DIR/config/dbw/paravan_ref.yaml, else the source tree's.
std::string default_protocol_config();

inline constexpr const char* kDefaultBusSocket = "/tmp/rig_paravan.sock";

}  // namespace sensor_rig::dbw
