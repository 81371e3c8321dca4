#pragma once
// Every DDS type the rig knows, by the name rmw_cyclonedds registers it under
// ("sensor_msgs::msg::dds_::PointCloud2_"), with Cyclone's descriptor (to create topics of it) and
// its ROS 2 schema ("sensor_msgs/msg/PointCloud2" and the ros2msg text with its dependencies, from
// msgs/ros2msg.hpp): what `rig record` writes into MCAP files, `rig play` reads back and `rig view`
// advertises. A type not listed here is unknown: callers report it and skip the topic.
#include <dds/dds.h>

#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::dds {

struct RegisteredType {
  std::string dds_name;     // "sensor_msgs::msg::dds_::PointCloud2_"
  std::string schema_name;  // "sensor_msgs/msg/PointCloud2" (MCAP schema name, rosbag2's spelling)
  std::string schema;       // ros2msg: the .msg text, then each dependency after its "MSG: pkg/Type" line
  const dds_topic_descriptor_t* descriptor = nullptr;
};

// Every registered type (sorted by dds_name); built on first use, immutable after, thread-safe.
const std::vector<RegisteredType>& registered_types();
// By DDS type name; nullptr when unknown.
const RegisteredType* find_type(std::string_view dds_name);
// By schema name, "pkg/msg/Type" or "pkg/Type"; nullptr when unknown.
const RegisteredType* find_type_by_schema(std::string_view schema_name);

// "pkg::msg::dds_::Type_" <-> "pkg/msg/Type" by the rmw_cyclonedds naming rule; "" when the name
// has another shape.
std::string schema_name_of(std::string_view dds_name);
std::string dds_name_of(std::string_view schema_name);

}  // namespace sensor_rig::dds
