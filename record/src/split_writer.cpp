#include "sensor_rig/record/split_writer.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace sensor_rig::record {

SplitWriter::SplitWriter(SplitOptions options) : opt_(std::move(options)) {
  split_ = opt_.split_bytes > 0 || opt_.split_ns > 0;
  namespace fs = std::filesystem;
  std::error_code ec;
  if (split_) {
    if (fs::exists(opt_.out, ec) && (!fs::is_directory(opt_.out, ec) || !fs::is_empty(opt_.out, ec)))
      throw McapError(opt_.out + " exists and is not an empty folder (a split recording is a folder of its own)");
    fs::create_directories(opt_.out, ec);
    if (ec) throw McapError("cannot create " + opt_.out + ": " + ec.message());
  } else if (fs::is_directory(opt_.out, ec)) {
    throw McapError(opt_.out + " is a folder: give a file NAME.mcap (or split with --split-mb / --split-s)");
  }
  open_next();
}

SplitWriter::~SplitWriter() = default;

void SplitWriter::open_next() {
  std::string path = opt_.out;
  if (split_) {
    std::string base = std::filesystem::path(opt_.out).filename().string();
    if (base.empty()) base = std::filesystem::path(opt_.out).parent_path().filename().string();
    path = (std::filesystem::path(opt_.out) / (base + "_" + std::to_string(files_.size()) + ".mcap")).string();
  }
  writer_ = std::make_unique<McapWriter>(path, opt_.mcap);
  files_.push_back(path);
  file_channel_.clear();
  file_schema_.clear();
  file_has_messages_ = false;
}

void SplitWriter::close_current() {
  writer_->close();
  const auto& done = writer_->stats();
  closed_totals_.messages += done.messages;
  closed_totals_.chunks += done.chunks;
  closed_totals_.uncompressed_bytes += done.uncompressed_bytes;
  closed_totals_.file_bytes += done.file_bytes;
  closed_totals_.compress_ns += done.compress_ns;
  closed_totals_.write_ns += done.write_ns;
  if (!split_) return;
  const Nanos t0 = monotonic_now_ns();
  closed_files_.push_back({std::filesystem::path(writer_->path()).filename().string(), done.message_start,
                           done.message_end, done.messages});
  const auto& counts = writer_->channel_counts();
  for (const auto& [key, id] : file_channel_)
    if (const auto it = counts.find(id); it != counts.end()) topic_messages_[key] += it->second;
  std::vector<BagTopicInfo> topics;
  for (std::size_t key = 0; key < channels_.size(); ++key) {
    if (topic_messages_[key] == 0) continue;  // a channel added, nothing of it in a complete file yet
    const auto& c = channels_[key];
    const auto qos = c.metadata.find("offered_qos_profiles");
    topics.push_back({c.topic, c.schema_name, c.message_encoding, qos != c.metadata.end() ? qos->second : "",
                      topic_messages_[key]});
  }
  write_bag_metadata(opt_.out, closed_files_, topics);
  metadata_ns_ += monotonic_now_ns() - t0;
}

std::size_t SplitWriter::add_channel(ChannelSpec spec) {
  channels_.push_back(std::move(spec));
  sequence_.push_back(0);
  topic_messages_.push_back(0);
  return channels_.size() - 1;
}

void SplitWriter::write(std::size_t channel, std::uint64_t log_time, std::uint64_t publish_time,
                        std::span<const std::span<const std::byte>> pieces) {
  if (split_ && file_has_messages_) {
    const auto& s = writer_->stats();
    const bool full_bytes = opt_.split_bytes > 0 && s.file_bytes + writer_->pending_bytes() >= opt_.split_bytes;
    const bool full_time = opt_.split_ns > 0 && log_time >= file_first_log_ + static_cast<std::uint64_t>(opt_.split_ns);
    if (full_bytes || full_time) {
      close_current();
      open_next();
    }
  }
  auto it = file_channel_.find(channel);
  if (it == file_channel_.end()) {
    const auto& c = channels_.at(channel);
    auto sit = file_schema_.find(c.schema_name);
    if (sit == file_schema_.end())
      sit = file_schema_.emplace(c.schema_name, writer_->add_schema(c.schema_name, c.schema_encoding, c.schema)).first;
    it = file_channel_.emplace(channel, writer_->add_channel(sit->second, c.topic, c.message_encoding, c.metadata)).first;
  }
  if (!file_has_messages_) {
    file_first_log_ = log_time;
    file_has_messages_ = true;
  }
  writer_->write(it->second, sequence_[channel]++, log_time, publish_time, pieces);
}

void SplitWriter::close() {
  if (!writer_ || closed_) return;
  closed_ = true;
  close_current();
}

McapWriterStats SplitWriter::totals() const {
  McapWriterStats t = closed_totals_;
  if (writer_ && !closed_) {
    const auto& s = writer_->stats();
    t.messages += s.messages;
    t.chunks += s.chunks;
    t.uncompressed_bytes += s.uncompressed_bytes;
    t.file_bytes += s.file_bytes;
    t.compress_ns += s.compress_ns;
    t.write_ns += s.write_ns;
  }
  return t;
}

}  // namespace sensor_rig::record
