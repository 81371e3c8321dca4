#pragma once
// The embedded .msg texts (generated msg_texts.cpp, from msgs/msg/<pkg>/<Type>.msg).
#include <cstddef>
#include <string_view>

namespace sensor_rig::msgs::detail {
struct EmbeddedMsg {
  std::string_view name;  // "pkg/Type"
  std::string_view text;  // the .msg file as written
};
extern const EmbeddedMsg kEmbeddedMsgs[];
extern const std::size_t kEmbeddedMsgCount;
}  // namespace sensor_rig::msgs::detail
