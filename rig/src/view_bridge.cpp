#include "view_bridge.hpp"

#include <cstdio>
#include <exception>
#include <span>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/dds/type_registry.hpp"

namespace sensor_rig::rig {
namespace {

constexpr std::int64_t kDiscoveryTag = 1;
constexpr std::int64_t kRequestTag = 2;

std::span<const std::uint8_t> as_u8(std::span<const std::byte> b) {
  return {reinterpret_cast<const std::uint8_t*>(b.data()), b.size()};
}

}  // namespace

ViewBridge::ViewBridge(const dds::Participant& participant, view::Server& server, int reader_depth)
    : participant_(participant), server_(server), reader_depth_(reader_depth), waitset_(participant),
      discovery_(participant) {
  waitset_.attach_reader(discovery_.handle(), kDiscoveryTag);
  waitset_.attach_guard(kRequestTag);
}

ViewBridge::~ViewBridge() {
  for (auto& [name, t] : topics_) close_reader(t);
}

void ViewBridge::request_reader(view::ChannelId channel, bool wanted) {
  {
    std::lock_guard lock(requests_mu_);
    requests_.emplace_back(channel, wanted);
  }
  waitset_.wake();
}

void ViewBridge::on_publication(const dds::Publication& pub) {
  if (!pub.alive) {
    const auto w = writer_topic_.find(pub.writer_guid);
    if (w == writer_topic_.end()) return;  // a writer we never listed (unknown type, not ROS)
    const auto it = topics_.find(w->second);
    writer_topic_.erase(w);
    if (it == topics_.end()) return;
    Topic& t = it->second;
    t.writers.erase(pub.writer_guid);
    t.best_effort_writers.erase(pub.writer_guid);
    t.transient_writers.erase(pub.writer_guid);
    if (!t.writers.empty()) return;
    // The topic's last writer went: clients are told (unadvertise), the reader goes.
    log::info("view", "unadvertised " + t.ros_name + " (no writer left)");
    close_reader(t);
    server_.remove_channel(t.channel);
    channel_topic_.erase(t.channel);
    topics_.erase(it);
    return;
  }
  // ROS topics only ("rt/..."): what Foxglove and Lichtblick name and decode.
  if (pub.topic.rfind("rt/", 0) != 0) return;
  const dds::RegisteredType* type = dds::find_type(pub.type);
  if (type == nullptr) {
    if (unknown_.emplace(pub.topic, pub.type).second)
      log::warn("view", dds::dds_to_ros_topic(pub.topic) + ": type " + pub.type +
                            " is not one the rig knows (no schema): not advertised");
    return;
  }
  auto [it, fresh] = topics_.try_emplace(pub.topic);
  Topic& t = it->second;
  if (fresh) {
    t.ros_name = dds::dds_to_ros_topic(pub.topic);
    t.type = type;
    t.channel = server_.add_channel(view::ChannelSpec{t.ros_name, "cdr", type->schema_name, type->schema, "ros2msg"});
    channel_topic_[t.channel] = pub.topic;
    log::info("view", "advertised " + t.ros_name + " (" + type->schema_name + ")");
  } else if (t.type != type) {
    if (type_conflicts_.insert(pub.topic).second)
      log::warn("view", t.ros_name + ": a writer of type " + pub.type + " beside writers of " + t.type->dds_name +
                            ": only the first type is shown");
    return;
  }
  t.writers.insert(pub.writer_guid);
  if (pub.reliability == dds::QosSpec::Reliability::kBestEffort) t.best_effort_writers.insert(pub.writer_guid);
  if (pub.durability == dds::QosSpec::Durability::kTransientLocal) t.transient_writers.insert(pub.writer_guid);
  writer_topic_[pub.writer_guid] = pub.topic;
}

void ViewBridge::open_reader(const std::string& dds_topic, Topic& t) {
  if (t.reader) return;
  // As the writers offer: reliable unless one of them is best-effort (a reliable reader would not
  // match it), transient-local when all are (a late viewer gets the last camera_info at once).
  dds::QosSpec q;
  q.reliability = t.best_effort_writers.empty() ? dds::QosSpec::Reliability::kReliable
                                                : dds::QosSpec::Reliability::kBestEffort;
  q.durability = !t.transient_writers.empty() && t.transient_writers.size() == t.writers.size()
                     ? dds::QosSpec::Durability::kTransientLocal
                     : dds::QosSpec::Durability::kVolatile;
  q.depth = reader_depth_;
  try {
    t.reader = std::make_unique<dds::RawReader>(participant_, dds_topic, *t.type, q);
    t.tag = next_tag_++;
    waitset_.attach_reader(t.reader->handle(), t.tag);
    tag_topic_[t.tag] = dds_topic;
    ++readers_opened_;
  } catch (const std::exception& e) {
    t.reader.reset();
    log::error("view", t.ros_name + ": cannot read it: " + e.what());
    server_.broadcast_status(view::StatusLevel::kError, t.ros_name + ": rig view cannot read it: " + e.what());
  }
}

void ViewBridge::close_reader(Topic& t) {
  if (!t.reader) return;
  t.reader->update_status();
  lost_ += t.reader->lost();
  rejected_ += t.reader->rejected();
  malformed_ += t.reader->malformed();
  waitset_.detach_reader(t.reader->handle());
  tag_topic_.erase(t.tag);
  t.reader.reset();
}

void ViewBridge::drain(Topic& t) {
  dds::RawSample s;
  // Bounded per wake-up, so one busy topic does not starve discovery and the others.
  for (int n = 0; n < 64 && t.reader && t.reader->take(s); ++n) {
    const std::span<const std::uint8_t> pieces[] = {as_u8(s.first()), as_u8(s.second())};
    server_.publish(t.channel, static_cast<std::uint64_t>(s.receive_ts()), pieces);
    ++t.forwarded;
  }
}

void ViewBridge::poll(std::int64_t timeout_ns) {
  waitset_.wait(triggered_, timeout_ns);
  for (const auto& pub : discovery_.take()) on_publication(pub);
  std::vector<std::pair<view::ChannelId, bool>> requests;
  {
    std::lock_guard lock(requests_mu_);
    // Under the lock: a request_reader() after this sets it again, so none is left unseen.
    waitset_.clear_guard();
    requests.swap(requests_);
  }
  for (const auto& [channel, wanted] : requests) {
    const auto c = channel_topic_.find(channel);
    if (c == channel_topic_.end()) continue;  // unadvertised meanwhile
    Topic& t = topics_.at(c->second);
    // The latest word counts: a subscribe and an unsubscribe in one batch end with the server's state.
    if (wanted && server_.has_subscribers(channel)) open_reader(c->second, t);
    if (!wanted && !server_.has_subscribers(channel)) close_reader(t);
  }
  for (const std::int64_t tag : triggered_) {
    const auto it = tag_topic_.find(tag);
    if (it == tag_topic_.end()) continue;
    drain(topics_.at(it->second));
  }
}

nlohmann::json ViewBridge::stats() {
  std::uint64_t lost = lost_, rejected = rejected_, malformed = malformed_;
  nlohmann::json readers = nlohmann::json::array();
  std::size_t advertised = 0;
  for (auto& [name, t] : topics_) {
    ++advertised;
    if (!t.reader) continue;
    t.reader->update_status();
    lost += t.reader->lost();
    rejected += t.reader->rejected();
    malformed += t.reader->malformed();
    readers.push_back({{"topic", t.ros_name}, {"forwarded", t.forwarded}, {"dds_lost", t.reader->lost()}});
  }
  nlohmann::json unknown = nlohmann::json::object();
  for (const auto& [topic, type] : unknown_) unknown[dds::dds_to_ros_topic(topic)] = type;
  return {{"advertised", advertised}, {"readers", readers}, {"readers_opened", readers_opened_},
          {"unknown_types", unknown}, {"dds_lost", lost}, {"dds_rejected", rejected}, {"malformed", malformed}};
}

}  // namespace sensor_rig::rig
