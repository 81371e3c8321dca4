#pragma once
// The Foxglove WebSocket protocol (subprotocol `foxglove.websocket.v1`, ws-protocol docs/spec.md):
// the server's JSON messages and binary frames, and the parse of what a client sends. Pure: no I/O,
// no clock; the server (server.hpp) moves these bytes.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace sensor_rig::view {

inline constexpr std::string_view kSubprotocol = "foxglove.websocket.v1";

using ChannelId = std::uint32_t;
using SubscriptionId = std::uint32_t;

// What a channel carries; `advertise` sends it with the id the server gave it.
struct ChannelSpec {
  std::string topic;            // the ROS name ("/sensors/lidar/front/points")
  std::string encoding;         // message encoding: "cdr"
  std::string schema_name;      // "sensor_msgs/msg/PointCloud2"
  std::string schema;           // the definition text, dependencies included
  std::string schema_encoding;  // "ros2msg"
  bool operator==(const ChannelSpec&) const = default;
};

struct Channel {
  ChannelId id = 0;
  ChannelSpec spec;
};

enum class StatusLevel : int { kInfo = 0, kWarning = 1, kError = 2 };

// Server -> client, text.
std::string server_info_json(std::string_view name, const std::vector<std::string>& capabilities,
                             std::string_view session_id);
std::string advertise_json(const std::vector<Channel>& channels);
std::string unadvertise_json(const std::vector<ChannelId>& ids);
std::string status_json(StatusLevel level, std::string_view message);

// Server -> client, binary (integers little-endian).
enum class BinaryOp : std::uint8_t { kMessageData = 0x01, kTime = 0x02 };
inline constexpr std::size_t kMessageDataHeaderBytes = 1 + 4 + 8;
inline constexpr std::size_t kTimeBytes = 1 + 8;
// Followed by the payload: opcode, subscription id, receive timestamp (ns).
std::array<std::uint8_t, kMessageDataHeaderBytes> message_data_header(SubscriptionId sub, std::uint64_t receive_ns);
std::array<std::uint8_t, kTimeBytes> time_message(std::uint64_t ns);

// Client -> server, text. Anything but a well-formed subscribe or unsubscribe is kError with the
// reason (the server answers it with a status error and keeps the connection).
struct ClientRequest {
  enum class Kind { kSubscribe, kUnsubscribe, kError };
  Kind kind = Kind::kError;
  std::vector<std::pair<SubscriptionId, ChannelId>> subscribe;  // (subscription id, channel id)
  std::vector<SubscriptionId> unsubscribe;
  std::string error;
};
ClientRequest parse_client_text(std::string_view text);

}  // namespace sensor_rig::view
