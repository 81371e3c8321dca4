#include "can_recording_log.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

constexpr std::size_t kAheadFrames = 65536;
constexpr const char* kSchema = "sensor_rig_msgs/msg/CanFrame";

// The CanFrame channels' topics of the file.
std::vector<std::string> can_topics(const record::McapReader& r) {
  std::vector<std::string> topics;
  for (const auto& [id, ch] : r.channels()) {
    const auto s = r.schemas().find(ch.schema_id);
    if (s == r.schemas().end() || s->second.name != kSchema || ch.message_encoding != "cdr") continue;
    if (std::find(topics.begin(), topics.end(), ch.topic) == topics.end()) topics.push_back(ch.topic);
  }
  return topics;
}

std::string pick(const std::vector<std::string>& topics) {
  if (std::find(topics.begin(), topics.end(), kCanFramesTopic) != topics.end()) return kCanFramesTopic;
  return topics.size() == 1 ? topics.front() : std::string{};
}

}  // namespace

McapCanLog::McapCanLog(const std::string& path) : path_(path) {
  try {
    reader_ = std::make_unique<record::McapReader>(path_);
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what());
  }
  auto topics = can_topics(*reader_);
  if (pick(topics).empty()) {
    reader_->load_channels_from_chunks();  // a file without a summary: channels inside chunks
    topics = can_topics(*reader_);
  }
  topic_ = pick(topics);
  if (topic_.empty()) {
    std::string seen;
    for (const auto& t : topics) seen += (seen.empty() ? "" : ", ") + t;
    throw std::runtime_error(path_ + ": no " + std::string(kSchema) + " channel " + kCanFramesTopic +
                             (topics.empty() ? std::string(" (none in the file: recorded without --raw?)")
                                             : " (several: " + seen + ")"));
  }
  for (const auto& p : reader_->problems()) log::warn("can", path_ + ": " + p.what);
  thread_ = std::thread([this] { produce(); });
}

McapCanLog::~McapCanLog() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void McapCanLog::produce() {
  std::vector<std::uint16_t> ids;
  for (const auto& [id, ch] : reader_->channels())
    if (ch.topic == topic_) ids.push_back(id);
  dds::CanFrameView view;
  std::string problems;
  std::uint64_t undecodable = 0;
  reader_->for_each_message([&](const record::McapMessage& m) {
    if (std::find(ids.begin(), ids.end(), m.channel_id) == ids.end()) {
      // A channel declared inside a later chunk (a file without a summary).
      const auto ch = reader_->channels().find(m.channel_id);
      if (ch == reader_->channels().end() || ch->second.topic != topic_) return true;
      ids.push_back(m.channel_id);
    }
    const auto body = dds::cdr_body(m.data);
    const dds::CdrStatus st = body ? dds::parse_cdr(*body, view) : dds::CdrStatus::kBadEncapsulation;
    dbw::can::LoggedFrame f;
    const bool fits = st == dds::CdrStatus::kOk && view.data.size() <= dbw::can::kFdMaxLen;
    if (!fits) {
      if (undecodable++ == 0)
        problems += "message " + std::to_string(m.sequence) + " of " + topic_ + " is not a CanFrame sample (" +
                    (st == dds::CdrStatus::kOk ? std::string("more than 64 data bytes") : std::string(dds::to_string(st))) +
                    "): skipped";
      std::lock_guard lock(mu_);
      ++malformed_;
      return true;
    }
    f.stamp = static_cast<Nanos>(view.header.sec) * 1'000'000'000 + static_cast<Nanos>(view.header.nanosec);
    f.frame.id = view.id;
    f.frame.rtr = view.is_rtr;
    f.frame.extended = view.is_extended;
    f.frame.error = view.is_error;
    f.frame.fd = view.is_fd;
    f.frame.brs = view.brs;
    f.frame.esi = view.esi;
    f.frame.len = static_cast<std::uint8_t>(view.data.size());
    std::copy(view.data.begin(), view.data.end(), reinterpret_cast<std::byte*>(f.frame.data.data()));
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return stop_ || queue_.size() < kAheadFrames; });
    if (stop_) return false;
    queue_.push_back(f);
    cv_.notify_all();
    return true;
  });
  if (undecodable > 1) problems += " (" + std::to_string(undecodable) + " such messages)";
  std::lock_guard lock(mu_);
  for (const auto& p : reader_->problems())
    problems_ += (problems_.empty() ? "" : "; ") + p.what;
  if (!problems.empty()) problems_ += (problems_.empty() ? "" : "; ") + problems;
  done_ = true;
  cv_.notify_all();
}

bool McapCanLog::next(dbw::can::LoggedFrame& out) {
  std::unique_lock lock(mu_);
  cv_.wait(lock, [&] { return !queue_.empty() || done_; });
  if (queue_.empty()) return false;
  out = queue_.front();
  queue_.pop_front();
  cv_.notify_all();
  return true;
}

std::uint64_t McapCanLog::malformed() const {
  std::lock_guard lock(mu_);
  return malformed_;
}

std::string McapCanLog::error() const {
  std::lock_guard lock(mu_);
  return done_ ? problems_ : std::string{};
}

std::unique_ptr<dbw::can::FrameLog> open_can_recording(const std::string& path) {
  return std::make_unique<McapCanLog>(path);
}

}  // namespace sensor_rig::rig
