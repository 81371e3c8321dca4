#pragma once
// Shared bits of the dbw commands: default paths.
#include <cstdlib>
#include <string>

namespace sensor_rig::dbw {

// The reference protocol mapping: $RIG_SOURCE_DIR/config/dbw/paravan_ref.yaml, else the source tree's.
inline std::string default_protocol_config() {
  const char* env = std::getenv("RIG_SOURCE_DIR");
  return std::string(env != nullptr ? env : RIG_DBW_SOURCE_DIR) + "/config/dbw/paravan_ref.yaml";
}

inline constexpr const char* kDefaultBusSocket = "/tmp/rig_paravan.sock";

}  // namespace sensor_rig::dbw
