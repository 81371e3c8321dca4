#pragma once
// /diagnostics during a `rig chaos` campaign: when the rig itself said a topic's stamps were not to
// be trusted. A status value `stamp_sync: unsynchronized` flags its topic (the status's `topic` value,
// or its name: camera/N -> /sensors/camera/N/image_raw, lidar/N -> /sensors/lidar/N/points); the
// judge does not count a stamp outside its bound against the rig while the topic was flagged.
// Also what the judge needs of the fused cloud: its sweeps' members (/rig/sets/fused) and the fusion
// node's count of scans it dropped (/diagnostics `fusion`, `scans_dropped`).
#include <atomic>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "chaos_check.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::rig::chaos {

using Intervals = std::vector<std::pair<Nanos, Nanos>>;  // vehicle time [begin, end)

// The topic a driver status speaks for ("" = none).
std::string status_topic(const std::string& status_name, const std::string& topic_value);

// When a topic was flagged, from its statuses: each flagged status covers the period before it and
// half a period after. Its stamp is the host clock when the rig published it; when that clock was
// stepped since the topic's previous status (its stamps moved apart by more than the time between
// their receptions, on CLOCK_MONOTONIC), the period before it was partly in the time before the
// step, so the flag also covers the elapsed time after the previous status, in that time. (A -37 s
// step undone: the two scans published in the 200 ms before the step forward were flagged by the
// status after it, stamped 37 s later, and judged unflagged.) Pure: fed by DiagnosticsLog.
class FlagSpans {
 public:
  void on_status(const std::string& topic, Nanos stamp, Nanos received_mono, bool flagged);
  [[nodiscard]] std::map<std::string, Intervals> intervals() const;

 private:
  struct Seen {
    Nanos stamp, mono;
    bool flagged;
  };
  std::map<std::string, Seen> last_;
  std::map<std::string, Intervals> spans_;
};

// A cumulative counter's statuses as (CLOCK_MONOTONIC when it came, value): its growth between two
// monotonic times, from its value in the last status at or before `begin` (0 before the first) to
// that in the last at or before `end`. Not by the statuses' stamps: one published while the host
// clock stood stepped back is stamped "before" the window though it came within it (a -37 s step at
// 5 s: 72 scans the fusion had counted dropped judged "neither fused nor counted dropped").
std::uint64_t counter_delta(const std::vector<std::pair<Nanos, std::uint64_t>>& statuses, Nanos begin, Nanos end);

class DiagnosticsLog {
 public:
  explicit DiagnosticsLog(const dds::DomainConfig& dds);
  ~DiagnosticsLog();
  DiagnosticsLog(const DiagnosticsLog&) = delete;
  DiagnosticsLog& operator=(const DiagnosticsLog&) = delete;

  // Per topic, when it was flagged: each flagged status covers the period before it (the rig
  // publishes once a period) and half a period after, merged.
  [[nodiscard]] std::map<std::string, Intervals> unsynchronized() const;
  // Every fused sweep's members received, in order.
  [[nodiscard]] std::vector<FusedSet> fused_sets() const;
  // A counter of a status (fusion/scans_dropped) between two CLOCK_MONOTONIC times (counter_delta).
  [[nodiscard]] std::uint64_t counter_delta(const std::string& status, const std::string& key, Nanos begin_mono, Nanos end_mono) const;
  // The messages of a status the judge reads (dbw/bridge: "STATE (REASON)"), with their stamps, in order.
  [[nodiscard]] std::vector<std::pair<Nanos, std::string>> messages(const std::string& status) const;
  // Why each topic was flagged: the status message of every flagged status that said something new
  // for its topic, in order (not judged: for whoever traces a campaign's flags, logs/flags.jsonl).
  struct FlagReason {
    Nanos stamp = 0;
    std::string topic;
    std::string message;
  };
  [[nodiscard]] std::vector<FlagReason> flag_reasons() const;

 private:
  void run();
  dds::Participant participant_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  FlagSpans flagged_;
  std::vector<FlagReason> flag_reasons_;
  std::map<std::string, std::string> last_reason_;  // topic -> its last flagged status's message
  std::map<std::string, std::vector<std::pair<Nanos, std::uint64_t>>> counters_;  // "status/key" -> (received mono, value)
  std::vector<FusedSet> fused_sets_;
  std::map<std::string, std::vector<std::pair<Nanos, std::string>>> messages_;  // status -> (stamp, message)
  std::thread thread_;
};

}  // namespace sensor_rig::rig::chaos
