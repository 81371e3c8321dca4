#include "sensor_rig/dbw/bridge/defaults.hpp"

#include <cstdlib>

namespace sensor_rig::dbw {

std::string default_protocol_config() {
  const char* env = std::getenv("RIG_SOURCE_DIR");
  return std::string(env != nullptr ? env : RIG_DBW_SOURCE_DIR) + "/config/dbw/paravan_ref.yaml";
}

}  // namespace sensor_rig::dbw
