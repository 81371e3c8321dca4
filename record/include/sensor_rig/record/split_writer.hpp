#pragma once
// A recording as one MCAP file or, split by size or time, a folder of them (rosbag2's layout:
// DIR/<name of DIR>_<N>.mcap from 0). Each file is complete on its own: a channel's Schema and
// Channel records go into every file that carries its messages, and the file is closed properly
// (summary, footer) before the next one starts. A split folder also gets rosbag2's metadata.yaml
// (record/bag_metadata.hpp), rewritten each time a file is closed: it lists every complete file, so
// after a kill it still names all but the file being written.
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/record/bag_metadata.hpp"
#include "sensor_rig/record/mcap_writer.hpp"

namespace sensor_rig::record {

struct SplitOptions {
  std::string out;                 // a file (no split) or a folder (split), created
  std::uint64_t split_bytes = 0;   // > 0: a new file once this many bytes are in the current one
  Nanos split_ns = 0;              // > 0: a new file once its messages span this much log time
  McapWriterOptions mcap;
};

struct ChannelSpec {
  std::string topic;
  std::string schema_name;
  std::string schema_encoding;  // "ros2msg"
  std::string schema;
  std::string message_encoding;  // "cdr"
  std::map<std::string, std::string> metadata;
};

class SplitWriter {
 public:
  // Creates the file, or the folder and its first file. Throws McapError (the folder exists and is
  // not empty, cannot be created, ...).
  explicit SplitWriter(SplitOptions options);
  ~SplitWriter();
  // A channel to write to; returns its key for write().
  std::size_t add_channel(ChannelSpec spec);
  // One message; starts the next file first when the current one is full. Throws McapError.
  void write(std::size_t channel, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::span<const std::byte>> pieces);
  // Closes the current file properly (and, split, writes metadata.yaml). Throws McapError.
  void close();

  [[nodiscard]] const std::vector<std::string>& files() const noexcept { return files_; }
  // Totals over every file so far (the current one's chunk in progress not in file_bytes).
  [[nodiscard]] McapWriterStats totals() const;
  // Time spent writing metadata.yaml, all files (ns).
  [[nodiscard]] std::int64_t metadata_ns() const noexcept { return metadata_ns_; }

 private:
  void open_next();
  // The current file closed: its counts into the totals, metadata.yaml rewritten.
  void close_current();
  SplitOptions opt_;
  bool split_ = false;
  bool closed_ = false;
  std::vector<ChannelSpec> channels_;
  std::vector<std::uint32_t> sequence_;
  std::unique_ptr<McapWriter> writer_;
  std::map<std::size_t, std::uint16_t> file_channel_;        // key -> channel id in the current file
  std::map<std::string, std::uint16_t> file_schema_;         // schema name -> id in the current file
  std::uint64_t file_first_log_ = 0;
  bool file_has_messages_ = false;
  std::vector<std::string> files_;
  McapWriterStats closed_totals_;
  std::vector<BagFileInfo> closed_files_;
  std::vector<std::uint64_t> topic_messages_;  // per channel key, closed files
  std::int64_t metadata_ns_ = 0;
};

}  // namespace sensor_rig::record
