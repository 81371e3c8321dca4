#pragma once
// What `rig monitor` knows per topic and per synchronized set, fed by its readers; no DDS here
// beyond the message structs.
#include <array>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <string_view>

#include "sample_record.hpp"
#include "sensor_rig/common/latency_window.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::rig {

struct Arrival {
  Nanos receive_ns = 0;
  Nanos publish_ns = 0;  // DDS source timestamp
};

// One topic: data samples and their source stamps, joined by header stamp (either may come first).
struct TopicStats {
  std::string name;
  std::uint64_t received = 0, lost = 0, source_drops = 0, missing_packets = 0, received_window = 0;
  std::uint64_t malformed = 0;  // clouds and images whose serialized bytes did not parse: dropped
  std::size_t last_size = 0;
  std::string info;  // what the last sample says, in a few words (points, speed, state...)
  std::array<LatencyWindow, kStageCount> stages;
  std::array<LatencyWindow, kStageCount> run_stages;  // whole run, for --summary
  std::map<Nanos, Arrival> unmatched_data;
  std::map<Nanos, SampleRecord> unmatched_stamps;  // received_ns holds "seen at" until matched
  std::map<std::uint64_t, SampleRecord> decided_by_seq;  // by seq, until the samples before are decided
  bool has_stamps = false;
  // Stamps published before this monitor subscribed to the data topic cannot be matched: ignored.
  Nanos counting_since = std::numeric_limits<Nanos>::max();
  // Called once per stamped sample, joined with its data or declared lost, in seq order: a sample
  // waits for the ones before it to be decided.
  std::function<void(const SampleRecord&)> on_record;

  void on_data(Nanos stamp, std::size_t size, const Arrival& a);
  void on_stamps(const msg::SourceStamps& s, Nanos now);
  // Stamps whose data has not come within loss_timeout_ns are lost; data without stamps is dropped.
  void expire(Nanos now, Nanos loss_timeout_ns);
  // At the end: hands every decided sample to on_record (undecided ones are neither).
  void release_all();

 private:
  void joined(SampleRecord r, const Arrival& a);
  void decided(SampleRecord r);
  void release(bool all);
  void add(std::size_t stage, double value);
};

// One synchronized set (/rig/sets/<name>): rate and spread from its samples, incomplete sets from
// the rig's /diagnostics (rig/sets/<name>: an incomplete set is never published).
struct SetStats {
  std::uint64_t received = 0, received_window = 0, incomplete = 0, dropped = 0, lost = 0;
  std::uint64_t next_seq = 0;
  bool any = false;
  std::size_t members = 0;
  LatencyWindow spread, run_spread;
  void on_set(const msg::SyncSet& m);
};

// A LIDAR-triggered camera (its /diagnostics status camera/<name> with trigger_lidar): the phase
// error of its triggers as the camera node measures it (drivers/camera/lidar_trigger.hpp).
struct TriggerStats {
  std::string lidar, sweep;
  std::uint64_t triggers = 0, measured = 0, unmeasured = 0;
  double p50_ms = 0, p99_ms = 0, max_ms = 0;
  // One key/value of the status; false when the key is not a trigger key (or the value is not a number).
  bool on_value(std::string_view key, std::string_view value);
};

}  // namespace sensor_rig::rig
