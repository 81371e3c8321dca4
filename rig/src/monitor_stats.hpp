#pragma once
// What `rig monitor` knows per topic and per synchronized set, fed by its readers; no DDS here
// beyond the message structs.
#include <algorithm>
#include <array>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sample_record.hpp"
#include "counting_gate.hpp"
#include "sensor_rig/common/latency_window.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::rig {

struct Arrival {
  Nanos receive_ns = 0;
  Nanos publish_ns = 0;  // DDS source timestamp
};

// Where a camera's frames went before the monitor (rig/README.md "Where a lost frame went"): its
// node's /diagnostics counters (camera/<name>), counted from the first status this monitor saw.
struct CameraDrops {
  // Aravis: no free pool buffer when a frame began (our pool is the stream's buffers); incomplete
  // frames by buffer status; the image_color/compressed worker's queue; failed image_raw writes
  // (a reliable writer blocked past max_blocking_ms by a reader that did not acknowledge).
  static constexpr std::array<std::string_view, 6> kKeys = {
      "underruns", "incomplete_timeout", "incomplete_missing_packets", "incomplete_other", "worker_dropped",
      "write_errors"};
  std::array<std::uint64_t, kKeys.size()> first{}, last{};
  bool seen = false;
  // One status's values (key, value); other keys are ignored.
  void on_status(const std::map<std::string, std::string, std::less<>>& values);
  // Since the first status (a restarted node's counters start again from 0).
  [[nodiscard]] std::uint64_t since_start(std::size_t i) const { return last[i] >= first[i] ? last[i] - first[i] : last[i]; }
  [[nodiscard]] std::uint64_t write_errors() const { return since_start(kKeys.size() - 1); }
};

// A node's cumulative counter from /diagnostics, counted since this monitor's first status (what
// came before is not its to count) and across a restart of the node (which counts from 0 again).
struct NodeTotal {
  std::uint64_t first = 0, last = 0, before_restart = 0;
  bool seen = false;
  void on(std::uint64_t cumulative);
  [[nodiscard]] std::uint64_t total() const { return before_restart + last - std::min(last, first); }
};

// One topic: data samples and their source stamps, joined by header stamp (either may come first).
struct TopicStats {
  std::string name;
  std::uint64_t received = 0, lost = 0, source_drops = 0, missing_packets = 0, received_window = 0;
  std::uint64_t malformed = 0;  // clouds and images whose serialized bytes did not parse: dropped
  // Loss accounting: data that came after its stamps were declared lost (no longer lost), data
  // whose stamps never came (not counted as lost), and what the reader's DDS said it lost.
  std::uint64_t late = 0, unstamped = 0, reader_lost = 0;
  // Stamped samples written before the first one this reader received: a reliable writer delivers
  // in order, so they were written before it matched this reader (start-up), never lost.
  std::uint64_t before_match = 0;
  bool data_seen = false;
  // Units the rig itself counted lost (issue 26 item 10): the node's /diagnostics `scans_lost` or
  // `frames_lost`.
  NodeTotal counted_lost_total;
  void on_counted_lost(std::uint64_t cumulative) { counted_lost_total.on(cumulative); }
  [[nodiscard]] std::uint64_t counted_lost() const { return counted_lost_total.total(); }
  // Turns a LIDAR without packet numbering heard nothing in, lost or never made (its node's
  // `scans_unheard`, lidar/include/sensor_rig/lidar/stream_gap.hpp): neither received nor lost.
  NodeTotal unheard_total;
  void on_unheard(std::uint64_t cumulative) { unheard_total.on(cumulative); }
  [[nodiscard]] std::uint64_t unheard() const { return unheard_total.total(); }
  // Samples whose stamps never came either: gaps in SourceStamps.seq per writer, counted in `lost`.
  std::uint64_t seq_gaps = 0;
  CameraDrops camera;  // camera image_raw topics: the node's drops by stage
  std::size_t last_size = 0;
  std::string info;  // what the last sample says, in a few words (points, speed, state...)
  std::array<LatencyWindow, kStageCount> stages;
  std::array<LatencyWindow, kStageCount> run_stages;  // whole run, for --summary
  std::map<Nanos, Arrival> unmatched_data;
  std::map<Nanos, SampleRecord> unmatched_stamps;  // received_ns holds "seen at" until matched
  struct Declared {
    Nanos at = 0, publish_ns = 0;
  };
  std::map<Nanos, Declared> declared_lost;  // by stamp: data still coming is late, not lost
  std::map<std::uint64_t, SampleRecord> decided_by_seq;  // by seq, until the samples before are decided
  bool has_stamps = false;
  // Stamps published before this monitor subscribed to the data topic cannot be matched: ignored.
  CountingGate counting;
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
  void first_data(Nanos publish_ns);
  void decided(SampleRecord r);
  void release(bool all);
  void add(std::size_t stage, double value);
};

// A topic's drops by stage, in pipeline order (name, count): a camera's node counters where its
// /diagnostics were seen, then the monitor's own. `lost_in_dds`: written, never delivered, and
// neither a failed write nor the reader's DDS status accounts for it — the writer's keep-last
// history dropped it before a repair finished (Cyclone 0.10 counts this nowhere an application can
// read), or the monitor's keep-last reader overwrote it.
std::vector<std::pair<std::string_view, std::uint64_t>> drops_by_stage(const TopicStats& st);

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
  // One part of the phase error, p50/p99/max in ms; `seen`: the node published it (it publishes
  // trigger_to_exposure only once the camera has reported an exposure start).
  struct Part {
    double p50_ms = 0, p99_ms = 0, max_ms = 0;
    bool seen = false;
  };
  std::string lidar, sweep;
  // Where the phase figure's exposure start comes from: device_exposure (the camera's own report)
  // or trigger_call (the host's trigger call + the configured latency); empty from an older node.
  std::string phase_from;
  std::uint64_t triggers = 0, measured = 0, unmeasured = 0, exposure_unmatched = 0;
  double p50_ms = 0, p99_ms = 0, max_ms = 0;
  Part call_error;   // the host's part: trigger call - sweep crossing
  Part to_exposure;  // the camera's part: exposure start - trigger call
  // One key/value of the status; false when the key is not a trigger key (or the value is not a number).
  bool on_value(std::string_view key, std::string_view value);
};

// `rig monitor`'s triggered-camera section: header and one row (<= 120 columns with the mock
// rig's names and figures under 10 ms), and the same figures for --json and --summary.
std::string trigger_table_header();
std::string trigger_table_row(const std::string& status_name, const TriggerStats& t);
nlohmann::json trigger_json(const std::string& status_name, const TriggerStats& t);

}  // namespace sensor_rig::rig
