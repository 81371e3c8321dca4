#pragma once
// The dbw DDS types (msgs/idl/sensor_rig_dbw.idl) registered with the typed wrapper.
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig_dbw.h"

namespace sensor_rig::msg {
using DbwCommand = sensor_rig_msgs_msg_dds__DbwCommand_;
using DbwStatus = sensor_rig_msgs_msg_dds__DbwStatus_;
using VehicleState = sensor_rig_msgs_msg_dds__VehicleState_;
}  // namespace sensor_rig::msg

RIG_DDS_TYPE(sensor_rig::msg::DbwCommand, sensor_rig_msgs_msg_dds__DbwCommand__desc);
RIG_DDS_TYPE(sensor_rig::msg::DbwStatus, sensor_rig_msgs_msg_dds__DbwStatus__desc);
RIG_DDS_TYPE(sensor_rig::msg::VehicleState, sensor_rig_msgs_msg_dds__VehicleState__desc);

namespace sensor_rig::dbw {
inline constexpr const char* kCmdTopic = "/vehicle/dbw/cmd";
inline constexpr const char* kStatusTopic = "/vehicle/dbw/status";
inline constexpr const char* kStateTopic = "/vehicle/state";
}  // namespace sensor_rig::dbw
