#include "sensor_rig/dds/type_registry.hpp"

#include <algorithm>
#include <stdexcept>

#include "builtin_interfaces.h"
#include "diagnostic_msgs.h"
#include "geometry_msgs.h"
#include "sensor_msgs.h"
#include "sensor_rig/msgs/ros2msg.hpp"
#include "sensor_rig_dbw.h"
#include "sensor_rig_msgs.h"
#include "sensor_rig_perf.h"
#include "std_msgs.h"

namespace sensor_rig::dds {
namespace {

// Every struct of msgs/idl: idlc generates a descriptor for each one.
const dds_topic_descriptor_t* const kDescriptors[] = {
    &builtin_interfaces_msg_dds__Time__desc,
    &builtin_interfaces_msg_dds__Duration__desc,
    &std_msgs_msg_dds__Header__desc,
    &geometry_msgs_msg_dds__Vector3__desc,
    &geometry_msgs_msg_dds__Quaternion__desc,
    &sensor_msgs_msg_dds__PointField__desc,
    &sensor_msgs_msg_dds__PointCloud2__desc,
    &sensor_msgs_msg_dds__Image__desc,
    &sensor_msgs_msg_dds__CompressedImage__desc,
    &sensor_msgs_msg_dds__RegionOfInterest__desc,
    &sensor_msgs_msg_dds__CameraInfo__desc,
    &sensor_msgs_msg_dds__Imu__desc,
    &sensor_msgs_msg_dds__NavSatStatus__desc,
    &sensor_msgs_msg_dds__NavSatFix__desc,
    &diagnostic_msgs_msg_dds__KeyValue__desc,
    &diagnostic_msgs_msg_dds__DiagnosticStatus__desc,
    &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
    &sensor_rig_msgs_msg_dds__SourceStamps__desc,
    &sensor_rig_msgs_msg_dds__SetMember__desc,
    &sensor_rig_msgs_msg_dds__SyncSet__desc,
    &sensor_rig_msgs_msg_dds__LidarPacket__desc,
    &sensor_rig_msgs_msg_dds__LidarPackets__desc,
    &sensor_rig_msgs_msg_dds__CanFrame__desc,
    &sensor_rig_msgs_msg_dds__DbwCommand__desc,
    &sensor_rig_msgs_msg_dds__DbwStatus__desc,
    &sensor_rig_msgs_msg_dds__VehicleState__desc,
    &sensor_rig_msgs_msg_dds__PerfHeader__desc,
    &sensor_rig_msgs_msg_dds__PerfSeq__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed0__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed16__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed64k__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed512k__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed1m__desc,
    &sensor_rig_msgs_msg_dds__PerfFixed2m__desc,
};

std::vector<RegisteredType> build() {
  std::vector<RegisteredType> types;
  for (const auto* desc : kDescriptors) {
    RegisteredType t;
    t.dds_name = desc->m_typename;
    t.schema_name = schema_name_of(t.dds_name);
    auto schema = msgs::ros2msg_schema(t.schema_name);
    // A type in msgs/idl without its .msg in msgs/msg is a build mistake the registry test catches.
    if (t.schema_name.empty() || !schema) throw std::logic_error("no ros2msg schema for " + t.dds_name);
    t.schema = std::move(*schema);
    t.descriptor = desc;
    types.push_back(std::move(t));
  }
  std::sort(types.begin(), types.end(), [](const auto& a, const auto& b) { return a.dds_name < b.dds_name; });
  return types;
}

}  // namespace

const std::vector<RegisteredType>& registered_types() {
  static const std::vector<RegisteredType> types = build();
  return types;
}

const RegisteredType* find_type(std::string_view dds_name) {
  const auto& types = registered_types();
  const auto it = std::lower_bound(types.begin(), types.end(), dds_name,
                                   [](const RegisteredType& t, std::string_view n) { return t.dds_name < n; });
  return it != types.end() && it->dds_name == dds_name ? &*it : nullptr;
}

const RegisteredType* find_type_by_schema(std::string_view schema_name) {
  const std::string dds_name = dds_name_of(schema_name);
  return dds_name.empty() ? nullptr : find_type(dds_name);
}

std::string schema_name_of(std::string_view dds_name) {
  // pkg::msg::dds_::Type_
  constexpr std::string_view kMid = "::msg::dds_::";
  const auto mid = dds_name.find(kMid);
  if (mid == std::string_view::npos || mid == 0 || !dds_name.ends_with('_')) return {};
  const std::string_view type = dds_name.substr(mid + kMid.size(), dds_name.size() - mid - kMid.size() - 1);
  if (type.empty() || type.find(':') != std::string_view::npos) return {};
  return std::string(dds_name.substr(0, mid)) + "/msg/" + std::string(type);
}

std::string dds_name_of(std::string_view schema_name) {
  const std::string full = msgs::schema_name(schema_name);  // pkg/msg/Type
  if (full.empty()) return {};
  const auto a = full.find('/');
  return full.substr(0, a) + "::msg::dds_::" + full.substr(full.rfind('/') + 1) + "_";
}

}  // namespace sensor_rig::dds
