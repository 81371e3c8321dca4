#include "lidar_recording_stream.hpp"

#include <algorithm>

namespace sensor_rig::rig {
namespace {

constexpr std::size_t kAheadBytes = 32u << 20;

McapChannelSpec lidar_channel(const std::string& topic) {
  McapChannelSpec spec;
  spec.schema = "sensor_rig_msgs/msg/LidarPackets";
  spec.pick = [topic](const std::vector<std::string>& topics) {
    return std::find(topics.begin(), topics.end(), topic) != topics.end() ? topic : std::string{};
  };
  spec.none = [topic, schema = spec.schema](const std::vector<std::string>& topics) {
    std::string seen;
    for (const auto& t : topics) seen += (seen.empty() ? "" : ", ") + t;
    return "no " + schema + " channel " + topic + " (raw LIDAR channels in the file: " + (seen.empty() ? "none" : seen) + ")";
  };
  spec.log_tag = "replay";
  spec.ahead = kAheadBytes;
  return spec;
}

}  // namespace

McapPacketStream::McapPacketStream(const std::string& path, const std::string& topic)
    : pump_(recording_files(path), lidar_channel(topic), [this](const auto& view, const auto& push) { return decode(view, push); },
            [](const Packet& p) { return p.bytes.size(); }) {}

std::string McapPacketStream::decode(const dds::LidarPacketsView& view, const std::function<bool(Packet&&)>& push) {
  {
    std::lock_guard lock(model_mu_);
    if (model_.empty()) model_ = std::string(view.model);
  }
  for (const auto& p : view.packets) {
    Packet q;
    q.time_ns = static_cast<Nanos>(p.sec) * 1'000'000'000 + static_cast<Nanos>(p.nanosec);
    q.position = p.dst_port != view.data_port;
    q.bytes.assign(p.data.begin(), p.data.end());
    if (!push(std::move(q))) break;  // closing
  }
  return {};
}

std::optional<lidar::mock::StreamPacket> McapPacketStream::next() {
  auto p = pump_.next();
  if (!p) return std::nullopt;
  current_ = std::move(*p);
  return lidar::mock::StreamPacket{current_.time_ns, current_.bytes, current_.position, -1, -1.0};
}

bool McapPacketStream::rewind() {
  pump_.rewind();
  return true;
}

std::string McapPacketStream::error() const { return pump_.error(); }

std::string McapPacketStream::model() const {
  std::lock_guard lock(model_mu_);
  return model_;
}

}  // namespace sensor_rig::rig
