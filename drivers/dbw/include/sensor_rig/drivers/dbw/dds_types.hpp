#pragma once
// The dbw DDS types (msgs/idl/sensor_rig_dbw.idl) are registered with the typed wrapper in
// sensor_rig/dds/types.hpp (one place for every type, so the monitor sees them too).
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::drivers {
inline constexpr const char* kCmdTopic = "/vehicle/dbw/cmd";
inline constexpr const char* kStatusTopic = "/vehicle/dbw/status";
inline constexpr const char* kStateTopic = "/vehicle/state";
}  // namespace sensor_rig::drivers
