#pragma once
// The rig's message types registered for the typed wrapper. Generated headers come from msgs/.
#include "builtin_interfaces.h"
#include "diagnostic_msgs.h"
#include "sensor_msgs.h"
#include "sensor_rig_dbw.h"
#include "sensor_rig_msgs.h"
#include "std_msgs.h"
#include "sensor_rig/dds/topic.hpp"

#include <vector>

namespace sensor_rig::msg {
using PointCloud2 = sensor_msgs_msg_dds__PointCloud2_;
using PointField = sensor_msgs_msg_dds__PointField_;
using Image = sensor_msgs_msg_dds__Image_;
using CompressedImage = sensor_msgs_msg_dds__CompressedImage_;
using CameraInfo = sensor_msgs_msg_dds__CameraInfo_;
using Imu = sensor_msgs_msg_dds__Imu_;
using NavSatFix = sensor_msgs_msg_dds__NavSatFix_;
using DiagnosticArray = diagnostic_msgs_msg_dds__DiagnosticArray_;
using DiagnosticStatus = diagnostic_msgs_msg_dds__DiagnosticStatus_;
using KeyValue = diagnostic_msgs_msg_dds__KeyValue_;
using SourceStamps = sensor_rig_msgs_msg_dds__SourceStamps_;
using SyncSet = sensor_rig_msgs_msg_dds__SyncSet_;
using SetMember = sensor_rig_msgs_msg_dds__SetMember_;
using LidarPacket = sensor_rig_msgs_msg_dds__LidarPacket_;
using LidarPackets = sensor_rig_msgs_msg_dds__LidarPackets_;
using CanFrame = sensor_rig_msgs_msg_dds__CanFrame_;
using Time = builtin_interfaces_msg_dds__Time_;
using DbwCommand = sensor_rig_msgs_msg_dds__DbwCommand_;
using DbwStatus = sensor_rig_msgs_msg_dds__DbwStatus_;
using VehicleState = sensor_rig_msgs_msg_dds__VehicleState_;
}  // namespace sensor_rig::msg

RIG_DDS_TYPE_WITH_PAYLOAD(sensor_rig::msg::PointCloud2, sensor_msgs_msg_dds__PointCloud2__desc, data);
RIG_DDS_TYPE_WITH_PAYLOAD(sensor_rig::msg::Image, sensor_msgs_msg_dds__Image__desc, data);
RIG_DDS_TYPE_WITH_PAYLOAD(sensor_rig::msg::CompressedImage, sensor_msgs_msg_dds__CompressedImage__desc, data);
RIG_DDS_TYPE(sensor_rig::msg::CameraInfo, sensor_msgs_msg_dds__CameraInfo__desc);
RIG_DDS_TYPE(sensor_rig::msg::Imu, sensor_msgs_msg_dds__Imu__desc);
RIG_DDS_TYPE(sensor_rig::msg::NavSatFix, sensor_msgs_msg_dds__NavSatFix__desc);
RIG_DDS_TYPE(sensor_rig::msg::DiagnosticArray, diagnostic_msgs_msg_dds__DiagnosticArray__desc);
RIG_DDS_TYPE(sensor_rig::msg::SourceStamps, sensor_rig_msgs_msg_dds__SourceStamps__desc);
RIG_DDS_TYPE(sensor_rig::msg::SyncSet, sensor_rig_msgs_msg_dds__SyncSet__desc);
RIG_DDS_TYPE(sensor_rig::msg::LidarPackets, sensor_rig_msgs_msg_dds__LidarPackets__desc);
RIG_DDS_TYPE(sensor_rig::msg::CanFrame, sensor_rig_msgs_msg_dds__CanFrame__desc);
RIG_DDS_TYPE(sensor_rig::msg::DbwCommand, sensor_rig_msgs_msg_dds__DbwCommand__desc);
RIG_DDS_TYPE(sensor_rig::msg::DbwStatus, sensor_rig_msgs_msg_dds__DbwStatus__desc);
RIG_DDS_TYPE(sensor_rig::msg::VehicleState, sensor_rig_msgs_msg_dds__VehicleState__desc);

namespace sensor_rig::msg {
inline Time to_time(Nanos ns) {
  Time t;
  const Nanos s = ns >= 0 ? ns / 1'000'000'000 : (ns - 999'999'999) / 1'000'000'000;
  t.sec = static_cast<std::int32_t>(s);
  t.nanosec = static_cast<std::uint32_t>(ns - s * 1'000'000'000);
  return t;
}
inline Nanos from_time(const Time& t) {
  return static_cast<Nanos>(t.sec) * 1'000'000'000 + static_cast<Nanos>(t.nanosec);
}

// PointCloud2.fields from a field table of {name, offset, datatype} (e.g. lidar::kPointFields). The
// names point into the table: it must outlive every sample that uses the result.
template <class FieldTable>
std::vector<PointField> point_fields(const FieldTable& table) {
  std::vector<PointField> fields;
  for (const auto& f : table) {
    PointField pf{};
    pf.name = const_cast<char*>(f.name);  // the C type is not const-correct; never written through
    pf.offset = f.offset;
    pf.datatype = f.datatype;
    pf.count = 1;
    fields.push_back(pf);
  }
  return fields;
}
}  // namespace sensor_rig::msg
