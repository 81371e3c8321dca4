#include "sensor_rig/record/bag_metadata.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/record/mcap_reader.hpp"
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

long split_file_index(const std::string& file) {
  namespace fs = std::filesystem;
  const fs::path p(file);
  std::string dir = p.parent_path().filename().string();
  if (dir.empty() || dir == "." || dir == "..")
    dir = fs::weakly_canonical(fs::absolute(p)).parent_path().filename().string();
  const std::string name = p.filename().string();
  const std::string prefix = dir + "_", suffix = ".mcap";
  if (dir.empty() || name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return -1;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::stol(digits);
}

BagRefresh refresh_bag_metadata(const std::string& folder) {
  namespace fs = std::filesystem;
  std::vector<std::pair<long, fs::path>> candidates;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const long n = split_file_index(e.path().string());
    if (n >= 0) candidates.emplace_back(n, e.path());
  }
  if (ec) throw McapError("cannot list " + folder + ": " + ec.message());
  std::sort(candidates.begin(), candidates.end());

  BagRefresh out;
  std::vector<BagFileInfo> files;
  std::vector<BagTopicInfo> topics;
  std::map<std::string, std::size_t> topic_at;  // name -> index in topics
  for (const auto& [n, path] : candidates) {
    const std::string name = path.filename().string();
    try {
      McapReader r(path.string());
      if (!r.complete() || !r.statistics()) {
        out.skipped.push_back(name + ": " +
                              (r.complete() ? std::string("no Statistics record in its summary")
                                            : std::string("not complete (no summary: repair it first)")));
        continue;
      }
      const McapStatistics& st = *r.statistics();
      files.push_back({name, st.message_start, st.message_end, st.message_count});
      out.listed.push_back(name);
      for (const auto& [id, c] : r.channels()) {
        const auto cnt = st.channel_message_counts.find(id);
        if (cnt == st.channel_message_counts.end() || cnt->second == 0) continue;
        auto at = topic_at.find(c.topic);
        if (at == topic_at.end()) {
          const auto schema = r.schemas().find(c.schema_id);
          const auto qos = c.metadata.find("offered_qos_profiles");
          topics.push_back({c.topic, schema != r.schemas().end() ? schema->second.name : "", c.message_encoding,
                            qos != c.metadata.end() ? qos->second : "", 0});
          at = topic_at.emplace(c.topic, topics.size() - 1).first;
        }
        topics[at->second].messages += cnt->second;
      }
    } catch (const McapError& e) {
      out.skipped.push_back(name + ": " + e.what());
    }
  }
  write_bag_metadata(folder, files, topics);
  return out;
}

}  // namespace sensor_rig::record
