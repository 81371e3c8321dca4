#pragma once
// The ROS 2 .msg definitions of every type the rig publishes (msgs/msg/<pkg>/<Type>.msg, embedded at
// build time) and the `ros2msg` schema text rosbag2 writes into MCAP files and Foxglove's WebSocket
// protocol advertises: the type's own .msg text, then every type it depends on, each once, depth
// first, as "\n" + 80 '=' + "\nMSG: pkg/Type\n" + its text. No DDS here: dds/type_registry.hpp joins
// these texts to Cyclone's descriptors (and tests check each one against the IDL, field by field).
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::msgs {

struct MsgField {
  enum class Kind { kSingle, kArray, kSequence };
  std::string type;  // primitive ("uint32", "string", "bool", "byte", "float64", ...) or "pkg/Type"
  std::string name;
  Kind kind = Kind::kSingle;
  std::uint32_t size = 0;  // kArray: its length; kSequence: its bound (0 = unbounded)
  std::uint32_t string_bound = 0;  // string<=N / wstring<=N: N (0 = unbounded)
  [[nodiscard]] bool is_primitive() const noexcept { return type.find('/') == std::string::npos; }
};

struct MsgDefinition {
  std::string name;  // "pkg/Type"
  std::vector<MsgField> fields;  // in order; constants are not fields
};

// "pkg/msg/Type" or "pkg/Type" -> "pkg/Type"; "" for anything else.
std::string short_name(std::string_view name);
// "pkg/Type" or "pkg/msg/Type" -> "pkg/msg/Type" (MCAP schema names, as rosbag2 writes them); "" for anything else.
std::string schema_name(std::string_view name);

// Parses the .msg text of `name` ("pkg/Type"): one field per line, constants (`TYPE NAME=VALUE`)
// and comments skipped. A type without a package is of `name`'s package (`Header` is
// std_msgs/Header, as in ROS). Throws std::invalid_argument naming the type and line.
MsgDefinition parse_msg(std::string_view name, std::string_view text);

// A whole ros2msg schema (the type's text, then the "MSG: pkg/Type" sections) parsed: the type
// itself first, then each section. Throws std::invalid_argument naming the section and line.
std::vector<MsgDefinition> parse_ros2msg_schema(std::string_view name, std::string_view schema);

// The embedded .msg text of a type ("pkg/Type" or "pkg/msg/Type"); nullopt when not embedded.
std::optional<std::string_view> msg_text(std::string_view name);
// Every embedded type, "pkg/Type", sorted.
std::vector<std::string_view> embedded_msg_names();

// The ros2msg schema of `name` as described above; nullopt when it or a dependency is not embedded.
std::optional<std::string> ros2msg_schema(std::string_view name);

}  // namespace sensor_rig::msgs
