#include "sync_sets_config.hpp"

#include <cmath>
#include <sstream>

namespace sensor_rig::rig {

timesync::SyncConfig SyncSetConfig::synchronizer_config() const {
  timesync::SyncConfig c;
  c.policy = policy;
  c.members = static_cast<std::uint32_t>(members.size());
  c.max_spread_ns = static_cast<Nanos>(std::llround(max_spread_ms * 1e6));
  c.timeout_ns = static_cast<Nanos>(std::llround(timeout_ms * 1e6));
  c.min_interval_ns.assign(members.size(), static_cast<Nanos>(std::llround(min_interval_ms * 1e6)));
  return c;
}

std::set<std::string> stamped_topics(const std::vector<drivers::LidarConfig>& lidars,
                                     const std::vector<drivers::CameraConfig>& cameras, const drivers::DbwConfig& dbw) {
  std::set<std::string> t;
  for (const auto& l : lidars) t.insert("/sensors/lidar/" + l.name + "/points");
  for (const auto& c : cameras) {
    t.insert("/sensors/camera/" + c.name + "/image_raw");
    if (c.outputs.color) t.insert("/sensors/camera/" + c.name + "/image_color");
  }
  if (dbw.enabled) t.insert("/vehicle/dbw/cmd");
  return t;
}

std::vector<SyncSetConfig> parse_sync_sets(const config::Node& root, const std::set<std::string>& known_topics) {
  std::vector<SyncSetConfig> out;
  std::set<std::string> names;
  for (const auto& item : root.items("sync_sets")) {
    if (!item.expect_map()) continue;
    item.allow_keys({"name", "members", "policy", "max_spread_ms", "timeout_ms", "min_interval_ms"});
    SyncSetConfig s;
    s.name = item.get_string("name");
    if (!s.name.empty()) {
      if (s.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos)
        item.fail("name", "'" + s.name + "': lower-case letters, digits and _ only (it becomes a topic name)");
      else if (s.name == "fused")  // the fused cloud's members go out on /rig/sets/fused (docs/topics.md)
        item.fail("name", "'fused' is the fused cloud's members set (/rig/sets/fused); choose another name");
      else if (!names.insert(s.name).second)
        item.fail("name", "duplicate set name '" + s.name + "'");
    }
    s.policy = item.get_enum<timesync::SyncPolicy>(
        "policy", {{"exact", timesync::SyncPolicy::kExact}, {"approximate", timesync::SyncPolicy::kApproximate}},
        timesync::SyncPolicy::kApproximate);
    s.max_spread_ms = item.get_double("max_spread_ms", 0, 10'000, 10);
    s.timeout_ms = item.get_double("timeout_ms", 1, 60'000, 500);
    s.min_interval_ms = item.get_double("min_interval_ms", 0, 60'000, 0);
    std::set<std::string> seen;
    for (const auto& m : item.items("members", true)) {
      if (!m.yaml().IsScalar()) {
        m.fail("", "expected a topic name");
        continue;
      }
      const std::string topic = m.yaml().Scalar();
      if (!known_topics.contains(topic)) {
        std::string known;
        for (const auto& k : known_topics) known.append(known.empty() ? "" : ", ").append(k);
        // NOLINTNEXTLINE(performance-inefficient-string-concatenation): a config error, once
        m.fail("", "unknown member topic '" + topic + "' (this rig publishes: " + known + ")");
      } else if (!seen.insert(topic).second) {
        m.fail("", "member '" + topic + "' listed twice");
      }
      s.members.push_back(topic);
    }
    if (item.has("members") && s.members.size() < 2) item.fail("members", "a set needs at least 2 members");
    if (s.members.size() > 64) item.fail("members", "at most 64 members");
    out.push_back(std::move(s));
  }
  return out;
}

std::string describe_sync_sets(const std::vector<SyncSetConfig>& sets) {
  std::ostringstream o;
  for (const auto& s : sets) {
    o << "  set " << s.name << ": " << s.members.size() << " members, " << timesync::to_string(s.policy);
    if (s.policy == timesync::SyncPolicy::kApproximate) o << " max spread " << s.max_spread_ms << " ms";
    o << ", timeout " << s.timeout_ms << " ms -> " << s.topic() << "\n";
  }
  return o.str();
}

}  // namespace sensor_rig::rig
