#include "lidar_recording_stream.hpp"

#include <stdexcept>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

constexpr std::size_t kAheadBytes = 32u << 20;
constexpr const char* kSchema = "sensor_rig_msgs/msg/LidarPackets";

// The channel ids of `topic` with the LidarPackets schema; the LidarPackets topics seen, for the error.
std::vector<std::uint16_t> channels_of(const record::McapReader& r, const std::string& topic, std::string& seen) {
  std::vector<std::uint16_t> ids;
  for (const auto& [id, ch] : r.channels()) {
    const auto s = r.schemas().find(ch.schema_id);
    if (s == r.schemas().end() || s->second.name != kSchema || ch.message_encoding != "cdr") continue;
    seen += (seen.empty() ? "" : ", ") + ch.topic;
    if (ch.topic == topic) ids.push_back(id);
  }
  return ids;
}

}  // namespace

McapPacketStream::McapPacketStream(std::string path, std::string topic) : path_(std::move(path)), topic_(std::move(topic)) {
  try {
    reader_ = std::make_unique<record::McapReader>(path_);
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what());
  }
  std::string seen;
  if (channels_of(*reader_, topic_, seen).empty()) {
    reader_->load_channels_from_chunks();  // a file without a summary: channels inside chunks
    seen.clear();
    if (channels_of(*reader_, topic_, seen).empty())
      throw std::runtime_error(path_ + ": no " + std::string(kSchema) + " channel " + topic_ +
                               " (raw LIDAR channels in the file: " + (seen.empty() ? "none" : seen) + ")");
  }
  for (const auto& p : reader_->problems()) log::warn("replay", path_ + ": " + p.what);
  start();
}

McapPacketStream::~McapPacketStream() { stop(); }

void McapPacketStream::start() {
  {
    std::lock_guard lock(mu_);
    queue_.clear();
    queued_bytes_ = 0;
    done_ = stop_ = false;
    problems_.clear();
  }
  thread_ = std::thread([this] { produce(); });
}

void McapPacketStream::stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void McapPacketStream::produce() {
  std::string seen;
  const std::vector<std::uint16_t> ids = channels_of(*reader_, topic_, seen);
  dds::LidarPacketsView view;
  std::string problems;
  std::uint64_t undecodable = 0;
  reader_->for_each_message([&](const record::McapMessage& m) {
    bool ours = false;
    for (const auto id : ids) ours = ours || id == m.channel_id;
    if (!ours) return true;
    const auto body = dds::cdr_body(m.data);
    const dds::CdrStatus st = body ? dds::parse_cdr(*body, view) : dds::CdrStatus::kBadEncapsulation;
    if (st != dds::CdrStatus::kOk) {
      if (undecodable++ == 0)
        problems += (problems.empty() ? "" : "; ") + std::string("message ") + std::to_string(m.sequence) + " of " +
                    topic_ + " is not a LidarPackets sample (" + dds::to_string(st) + "): skipped";
      return true;
    }
    std::unique_lock lock(mu_);
    if (model_.empty()) model_ = std::string(view.model);
    for (const auto& p : view.packets) {
      cv_.wait(lock, [&] { return stop_ || queued_bytes_ < kAheadBytes; });
      if (stop_) return false;
      Packet q;
      q.time_ns = static_cast<Nanos>(p.sec) * 1'000'000'000 + static_cast<Nanos>(p.nanosec);
      q.position = p.dst_port != view.data_port;
      q.bytes.assign(p.data.begin(), p.data.end());
      queued_bytes_ += q.bytes.size();
      queue_.push_back(std::move(q));
      cv_.notify_all();
    }
    return true;
  });
  if (undecodable > 1) problems += " (" + std::to_string(undecodable) + " such messages)";
  std::lock_guard lock(mu_);
  for (const auto& p : reader_->problems()) problems_ += (problems_.empty() ? "" : "; ") + p.what;
  if (!problems.empty()) problems_ += (problems_.empty() ? "" : "; ") + problems;
  done_ = true;
  cv_.notify_all();
}

std::optional<lidar::mock::StreamPacket> McapPacketStream::next() {
  std::unique_lock lock(mu_);
  cv_.wait(lock, [&] { return !queue_.empty() || done_; });
  if (queue_.empty()) return std::nullopt;
  current_ = std::move(queue_.front());
  queue_.pop_front();
  queued_bytes_ -= current_.bytes.size();
  cv_.notify_all();
  return lidar::mock::StreamPacket{current_.time_ns, current_.bytes, current_.position, -1, -1.0};
}

bool McapPacketStream::rewind() {
  stop();
  start();
  return true;
}

std::string McapPacketStream::error() const {
  std::lock_guard lock(mu_);
  return done_ ? problems_ : std::string{};
}

std::string McapPacketStream::model() const {
  std::lock_guard lock(mu_);
  return model_;
}

}  // namespace sensor_rig::rig
