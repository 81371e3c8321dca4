#include "chaos_diagnostics.hpp"

#include <algorithm>
#include <string_view>

#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::rig::chaos {
namespace {

// The rig publishes /diagnostics once a period (rig.diagnostics_period_ms, 1 s in the shipped
// configs): a flag covers the period before its status, and half of one after.
constexpr Nanos kBefore = 1'500'000'000;
constexpr Nanos kAfter = 500'000'000;

}  // namespace

std::string status_topic(const std::string& name, const std::string& topic_value) {
  if (!topic_value.empty()) return topic_value;
  if (name.rfind("camera/", 0) == 0) return "/sensors/camera/" + name.substr(7) + "/image_raw";
  if (name.rfind("lidar/", 0) == 0) return "/sensors/lidar/" + name.substr(6) + "/points";
  return {};
}

DiagnosticsLog::DiagnosticsLog(const dds::DomainConfig& dds) : participant_(dds) {
  thread_ = std::thread([this] { run(); });
}

DiagnosticsLog::~DiagnosticsLog() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void DiagnosticsLog::run() {
  const dds::Topic<msg::DiagnosticArray> topic(participant_, "/diagnostics");
  const dds::Reader<msg::DiagnosticArray> reader(participant_, topic);
  while (!stop_) {
    if (!reader.wait(100)) continue;
    reader.take(
        [&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
          const Nanos t = msg::from_time(a.header.stamp);
          for (std::uint32_t i = 0; i < a.status._length; ++i) {
            const auto& st = a.status._buffer[i];
            bool flagged = false;
            std::string topic_value;
            for (std::uint32_t k = 0; k < st.values._length; ++k) {
              const auto& kv = st.values._buffer[k];
              if (kv.key == nullptr || kv.value == nullptr) continue;
              const std::string_view key(kv.key), value(kv.value);
              if (key == "stamp_sync" && value == "unsynchronized") flagged = true;
              if (key == "topic") topic_value = kv.value;
            }
            if (!flagged) continue;
            const std::string topic_name = status_topic(st.name != nullptr ? st.name : "", topic_value);
            if (topic_name.empty()) continue;
            std::lock_guard lock(mutex_);
            flagged_[topic_name].push_back(t);
          }
        },
        64);
  }
}

std::map<std::string, Intervals> DiagnosticsLog::unsynchronized() const {
  std::lock_guard lock(mutex_);
  std::map<std::string, Intervals> out;
  for (auto [topic, stamps] : flagged_) {
    std::sort(stamps.begin(), stamps.end());
    Intervals& iv = out[topic];
    for (const Nanos t : stamps) {
      if (!iv.empty() && t - kBefore <= iv.back().second) iv.back().second = std::max(iv.back().second, t + kAfter);
      else iv.emplace_back(t - kBefore, t + kAfter);
    }
  }
  return out;
}

}  // namespace sensor_rig::rig::chaos
