#include "chaos_diagnostics.hpp"

#include <algorithm>
#include <cstdlib>
#include <string_view>

#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::rig::chaos {
namespace {

// The rig publishes /diagnostics once a period (rig.diagnostics_period_ms, 1 s in the shipped
// configs): a flag covers the period before its status, and half of one after.
constexpr Nanos kBefore = 1'500'000'000;
constexpr Nanos kAfter = 500'000'000;
// A status older than this no longer says anything (ROS diagnostic_aggregator's default stale timeout).
constexpr Nanos kStaleAfter = 5'000'000'000;

// The counters the judge reads, as "status/key": the fusion's dropped scans, the dbw bridge's
// feedback counter gaps it could not size.
bool watched_counter(std::string_view status, std::string_view key) {
  return (status == "fusion" && key == "scans_dropped") || (status == "dbw/vehicle_state" && key == "gaps_unknown");
}
// The statuses whose messages the judge reads: the bridge's state and reason (its ECU watchdog).
bool watched_message(std::string_view status) { return status == "dbw/bridge"; }

dds::QosSpec sets_qos() {  // deeper than the writer's 16: the reader is polled every 100 ms
  dds::QosSpec q;
  q.depth = 64;
  return q;
}

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
  const dds::Topic<msg::SyncSet> sets_topic(participant_, "/rig/sets/fused", sets_qos());
  const dds::Reader<msg::SyncSet> sets(participant_, sets_topic, sets_qos());
  while (!stop_) {
    (void)reader.wait(100);
    sets.take(
        [&](const msg::SyncSet& m, const dds_sample_info_t&) {
          FusedSet set{m.set_seq, msg::from_time(m.header.stamp), {}};
          for (std::uint32_t i = 0; i < m.members._length; ++i) {
            const auto& mm = m.members._buffer[i];
            set.members.push_back({mm.topic != nullptr ? mm.topic : "", msg::from_time(mm.stamp), mm.seq});
          }
          std::lock_guard lock(mutex_);
          fused_sets_.push_back(std::move(set));
        },
        256);
    reader.take(
        [&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
          const Nanos t = msg::from_time(a.header.stamp), received = monotonic_now_ns();
          for (std::uint32_t i = 0; i < a.status._length; ++i) {
            const auto& st = a.status._buffer[i];
            if (st.name != nullptr && st.message != nullptr && watched_message(st.name)) {
              std::lock_guard lock(mutex_);
              messages_[st.name].emplace_back(t, st.message);
            }
            bool flagged = false;
            std::string topic_value;
            for (std::uint32_t k = 0; k < st.values._length; ++k) {
              const auto& kv = st.values._buffer[k];
              if (kv.key == nullptr || kv.value == nullptr) continue;
              const std::string_view key(kv.key), value(kv.value);
              if (key == "stamp_sync" && value == "unsynchronized") flagged = true;
              if (key == "topic") topic_value = kv.value;
              if (st.name != nullptr && watched_counter(st.name, key)) {
                std::lock_guard lock(mutex_);
                counters_[std::string(st.name) + "/" + kv.key].emplace_back(received, std::strtoull(kv.value, nullptr, 10));
              }
            }
            const std::string topic_name = status_topic(st.name != nullptr ? st.name : "", topic_value);
            if (topic_name.empty()) continue;
            std::lock_guard lock(mutex_);
            flagged_.on_status(topic_name, t, received, flagged);
            if (!flagged) continue;
            const std::string message = st.message != nullptr ? st.message : "";
            if (auto& last = last_reason_[topic_name]; last != message) {
              last = message;
              flag_reasons_.push_back({t, topic_name, message});
            }
          }
        },
        64);
  }
}

std::vector<FusedSet> DiagnosticsLog::fused_sets() const {
  std::lock_guard lock(mutex_);
  return fused_sets_;
}

std::uint64_t counter_delta(const std::vector<std::pair<Nanos, std::uint64_t>>& statuses, Nanos begin, Nanos end) {
  std::uint64_t at_begin = 0, at_end = 0;
  for (const auto& [received, v] : statuses) {
    if (received <= begin) at_begin = v;
    if (received <= end) at_end = v;
  }
  return at_end - std::min(at_end, at_begin);
}

std::uint64_t DiagnosticsLog::counter_delta(const std::string& status, const std::string& key, Nanos begin_mono, Nanos end_mono) const {
  std::lock_guard lock(mutex_);
  const auto it = counters_.find(status + "/" + key);
  return it == counters_.end() ? 0 : chaos::counter_delta(it->second, begin_mono, end_mono);
}

std::vector<std::pair<Nanos, std::string>> DiagnosticsLog::messages(const std::string& status) const {
  std::lock_guard lock(mutex_);
  const auto it = messages_.find(status);
  if (it == messages_.end()) return {};
  auto out = it->second;
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

std::vector<DiagnosticsLog::FlagReason> DiagnosticsLog::flag_reasons() const {
  std::lock_guard lock(mutex_);
  return flag_reasons_;
}

void FlagSpans::on_status(const std::string& topic, Nanos stamp, Nanos received_mono, bool flagged) {
  // Reception is polled (100 ms) and DDS adds its latency: a difference beyond this is a step.
  constexpr Nanos kStepSeen = 300'000'000;
  const auto prev = last_.find(topic);
  if (flagged) {
    auto& spans = spans_[topic];
    spans.emplace_back(stamp - kBefore, stamp + kAfter);
    if (prev != last_.end()) {
      const Nanos elapsed = received_mono - prev->second.mono, moved = stamp - prev->second.stamp;
      if (elapsed > 0 && (moved - elapsed > kStepSeen || elapsed - moved > kStepSeen))
        spans.emplace_back(prev->second.stamp, prev->second.stamp + elapsed);
      // Flagged, and flagged in the status before with none between: flagged throughout, as a
      // diagnostics consumer shows the last status until the next (a ROS aggregator calls it stale
      // after 5 s). The rig's statuses came 2.5 s apart once, no fault near (ten-minute campaign,
      // seed 9: every node's, around a camera's reopen), and the samples published in the second
      // between two flagged statuses were judged unflagged (27.8 s off, slewing out a -37 s step).
      if (prev->second.flagged && moved > 0 && moved <= kStaleAfter) spans.emplace_back(prev->second.stamp, stamp);
    }
  }
  last_.insert_or_assign(topic, Seen{stamp, received_mono, flagged});
}

std::map<std::string, Intervals> FlagSpans::intervals() const {
  std::map<std::string, Intervals> out;
  for (auto [topic, spans] : spans_) {
    std::sort(spans.begin(), spans.end());
    Intervals& iv = out[topic];
    for (const auto& [b, e] : spans) {
      if (!iv.empty() && b <= iv.back().second) iv.back().second = std::max(iv.back().second, e);
      else iv.emplace_back(b, e);
    }
  }
  return out;
}

std::map<std::string, Intervals> DiagnosticsLog::unsynchronized() const {
  std::lock_guard lock(mutex_);
  return flagged_.intervals();
}

}  // namespace sensor_rig::rig::chaos
