#include "mcap_channel_pump.hpp"

#include <algorithm>
#include <stdexcept>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig {
namespace {

// The topics of the reader's cdr channels of `schema`, each once.
std::vector<std::string> topics_of(const record::McapReader& r, const std::string& schema) {
  std::vector<std::string> topics;
  for (const auto& [id, ch] : r.channels()) {
    const auto s = r.schemas().find(ch.schema_id);
    if (s == r.schemas().end() || s->second.name != schema || ch.message_encoding != "cdr") continue;
    if (std::find(topics.begin(), topics.end(), ch.topic) == topics.end()) topics.push_back(ch.topic);
  }
  return topics;
}

}  // namespace

void append_problem(std::string& a, const std::string& b) {
  if (!b.empty()) a += (a.empty() ? "" : "; ") + b;
}

McapChannelFile::McapChannelFile(const std::string& path, const McapChannelSpec& spec) : schema_(spec.schema) {
  try {
    reader_ = std::make_unique<record::McapReader>(path);
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what());
  }
  auto topics = topics_of(*reader_, schema_);
  topic_ = spec.pick(topics);
  if (topic_.empty()) {
    reader_->load_channels_from_chunks();  // a file without a summary: channels inside chunks
    topics = topics_of(*reader_, schema_);
    topic_ = spec.pick(topics);
  }
  if (topic_.empty()) throw McapNoChannel(path + ": " + spec.none(topics));
  for (const auto& p : reader_->problems()) log::warn(spec.log_tag, path + ": " + p.what);
}

bool McapChannelFile::ours(std::uint16_t channel_id) const {
  // Looked up per message: a file without a summary declares channels inside later chunks.
  const auto ch = reader_->channels().find(channel_id);
  if (ch == reader_->channels().end() || ch->second.topic != topic_ || ch->second.message_encoding != "cdr") return false;
  const auto s = reader_->schemas().find(ch->second.schema_id);
  return s != reader_->schemas().end() && s->second.name == schema_;
}

void McapChannelFile::for_each(const std::function<bool(const record::McapMessage&)>& fn) {
  reader_->for_each_message([&](const record::McapMessage& m) { return !ours(m.channel_id) || fn(m); });
}

std::string McapChannelFile::problems(const std::string& where) const {
  std::string out;
  for (const auto& p : reader_->problems()) append_problem(out, where + p.what);
  return out;
}

FirstChannelFile open_first_channel_file(const std::vector<std::string>& files, const McapChannelSpec& spec) {
  std::string damaged, first_error;
  for (std::size_t i = 0; i < files.size(); ++i) {
    try {
      return FirstChannelFile{i, McapChannelFile(files[i], spec), damaged};
    } catch (const McapNoChannel& e) {
      if (first_error.empty()) first_error = e.what();
    } catch (const std::exception& e) {
      if (first_error.empty()) first_error = e.what();
      append_problem(damaged, e.what());
    }
  }
  if (files.size() > 1) first_error += " (nor in the recording's " + std::to_string(files.size() - 1) + " other files)";
  throw std::runtime_error(first_error);
}

}  // namespace sensor_rig::rig
