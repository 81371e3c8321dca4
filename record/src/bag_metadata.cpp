#include "sensor_rig/record/bag_metadata.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::record {
namespace {

// A YAML double-quoted scalar: any text (the QoS profiles span lines) read back exactly.
std::string quoted(const std::string& s) {
  std::string o = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      case '\r': o += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char hex[8];
          std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          o += hex;
        } else {
          o += c;
        }
    }
  }
  return o + "\"";
}

}  // namespace

std::string bag_metadata_yaml(const std::vector<BagFileInfo>& files, const std::vector<BagTopicInfo>& topics) {
  std::uint64_t start = 0, end = 0, messages = 0;
  bool any = false;
  for (const auto& f : files) {
    messages += f.messages;
    if (f.messages == 0) continue;
    start = any ? std::min(start, f.start_ns) : f.start_ns;
    end = any ? std::max(end, f.end_ns) : f.end_ns;
    any = true;
  }
  std::ostringstream o;
  // Keys in the order rosbag2's encoder writes them (rosbag2_storage/yaml.hpp).
  o << "rosbag2_bagfile_information:\n"
    << "  version: " << kBagMetadataVersion << "\n"
    << "  storage_identifier: mcap\n"
    << "  duration:\n    nanoseconds: " << end - start << "\n"
    << "  starting_time:\n    nanoseconds_since_epoch: " << start << "\n"
    << "  message_count: " << messages << "\n"
    << "  topics_with_message_count:" << (topics.empty() ? " []" : "") << "\n";
  for (const auto& t : topics) {
    o << "    - topic_metadata:\n"
      << "        name: " << quoted(t.name) << "\n"
      << "        type: " << quoted(t.type) << "\n"
      << "        serialization_format: " << quoted(t.serialization_format) << "\n"
      << "        offered_qos_profiles: " << quoted(t.offered_qos_profiles) << "\n"
      << "      message_count: " << t.messages << "\n";
  }
  o << "  compression_format: \"\"\n"
    << "  compression_mode: \"\"\n"
    << "  relative_file_paths:" << (files.empty() ? " []" : "") << "\n";
  for (const auto& f : files) o << "    - " << quoted(f.path) << "\n";
  o << "  files:" << (files.empty() ? " []" : "") << "\n";
  for (const auto& f : files) {
    o << "    - path: " << quoted(f.path) << "\n"
      << "      starting_time:\n        nanoseconds_since_epoch: " << (f.messages > 0 ? f.start_ns : 0) << "\n"
      << "      duration:\n        nanoseconds: " << (f.messages > 0 ? f.end_ns - f.start_ns : 0) << "\n"
      << "      message_count: " << f.messages << "\n";
  }
  return o.str();
}

void write_bag_metadata(const std::string& folder, const std::vector<BagFileInfo>& files,
                        const std::vector<BagTopicInfo>& topics) {
  const std::string text = bag_metadata_yaml(files, topics);
  const std::string path = (std::filesystem::path(folder) / "metadata.yaml").string();
  const std::string tmp = path + ".tmp";
  {
    UniqueFd fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (!fd) throw McapError("cannot create " + tmp + ": " + std::strerror(errno));
    std::size_t done = 0;
    while (done < text.size()) {
      const ssize_t w = ::write(fd.get(), text.data() + done, text.size() - done);
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) {
        const std::string why = std::strerror(errno);
        ::unlink(tmp.c_str());
        throw McapError("write to " + tmp + " failed: " + why);
      }
      done += static_cast<std::size_t>(w);
    }
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw McapError("cannot rename " + tmp + " to " + path + ": " + why);
  }
}

}  // namespace sensor_rig::record
