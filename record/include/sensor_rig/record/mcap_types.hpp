#pragma once
// The MCAP records the rig writes and reads (https://mcap.dev/spec, major version 0), and the error
// both sides throw.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::record {

struct McapError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class Compression { kNone, kLz4, kZstd };
// "none" | "lz4" | "zstd"; nullopt for anything else.
std::optional<Compression> parse_compression(std::string_view s);
// As MCAP names it in a chunk: "", "lz4", "zstd".
std::string_view mcap_name(Compression c);

struct McapSchema {
  std::uint16_t id = 0;
  std::string name;      // "sensor_msgs/msg/PointCloud2"
  std::string encoding;  // "ros2msg"
  std::string data;      // the schema text
};

struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;             // ROS name, "/sensors/lidar/front/points"
  std::string message_encoding;  // "cdr"
  std::map<std::string, std::string> metadata;  // "offered_qos_profiles": rosbag2's YAML
};

struct McapMessage {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // ns; the rig: receive time (CLOCK_REALTIME)
  std::uint64_t publish_time = 0;  // ns; the rig: the writer's DDS source timestamp
  std::span<const std::byte> data;
};

namespace opcode {
inline constexpr std::uint8_t kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05,
                              kChunk = 0x06, kMessageIndex = 0x07, kChunkIndex = 0x08, kAttachment = 0x09,
                              kAttachmentIndex = 0x0A, kStatistics = 0x0B, kMetadata = 0x0C,
                              kMetadataIndex = 0x0D, kSummaryOffset = 0x0E, kDataEnd = 0x0F;
}
inline constexpr std::byte kMagic[8] = {std::byte{0x89}, std::byte{'M'}, std::byte{'C'}, std::byte{'A'},
                                        std::byte{'P'},  std::byte{'0'}, std::byte{'\r'}, std::byte{'\n'}};

// CRC-32 (ISO-HDLC, zlib's), as MCAP uses it; `crc` continues a previous value (0 to start).
std::uint32_t crc32(std::span<const std::byte> data, std::uint32_t crc = 0) noexcept;

}  // namespace sensor_rig::record
