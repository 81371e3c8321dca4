#pragma once
// The judge of `rig chaos`: the rig's output (every stamped sample as `rig monitor --record` saw it,
// the monitor's totals, the units the rig itself counted lost) held against the mocks' truth records
// and the fault plan. Pure: everything comes in as data, so each invariant is tested with planted
// violations (tests/rig/chaos_check_test.cpp). docs/faults.md "Invariants" explains each one.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "sample_record.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::rig::chaos {

// Stated bounds (docs/faults.md "Bounds" says why each is what it is).
struct Bounds {
  double lidar_stamp_ms = 0.1;   // a scan's stamp vs its first firing: the sensors stamp in µs
  double camera_stamp_ms = 1.0;  // a frame's stamp vs its exposure start: mapped from the camera clock
  double other_stamp_ms = 5.0;   // drive-by-wire: kernel receive time of a 10 ms status period
  double lidar_recovery_s = 1.0;   // a LIDAR is back within this after a fault ends
  double camera_recovery_s = 5.0;  // a camera (reopened by the driver) is back within this
  double other_recovery_s = 2.0;
  double isolation_min = 0.95;     // a healthy device keeps this share of its rate
  double settle_s = 1.0;           // after a fault ends, its device is not yet "healthy" for this long
};

// What the monitor said at its end, per topic (its last --json line).
struct MonitorTotals {
  std::uint64_t received = 0;
  std::uint64_t lost = 0;
};

struct TopicExpectation {
  std::string device;
  double rate_hz = 0;  // nominal units per second (config), for isolation of a starved device
  std::vector<std::string> depends_on;  // devices whose faults it rightly suffers (a triggered camera's LIDAR)
};

// The fused cloud (/sensors/lidar/fused/points): the members of each sweep as the fusion node
// published them (/rig/sets/fused), and the scans it counted dropped (/diagnostics `fusion`).
struct FusedMember {
  std::string topic;
  Nanos stamp = 0;
  std::uint64_t seq = 0;  // on /rig/stamps
};
struct FusedSet {
  std::uint64_t seq = 0;  // = the fused cloud's seq on /rig/stamps
  Nanos stamp = 0;        // = the fused cloud's header.stamp
  std::vector<FusedMember> members;
};
struct FusedInput {
  bool enabled = false;                   // the config fuses its LIDARs: judged
  std::vector<std::string> lidar_topics;  // the LIDARs fused, config order
  Nanos period_ns = 100'000'000;          // one rotation (fusion.max_spread_ms): what "one rotation" means
  std::vector<FusedSet> sets;
  std::uint64_t scans_dropped = 0;        // fusion's scans_dropped counted in the window
};

struct Input {
  std::vector<truth::Log> truths;
  std::vector<faults::FaultEvent> events;  // the plan
  Nanos epoch_vehicle_ns = 0;              // vehicle time at the plan's t = 0
  std::vector<SampleRecord> samples;       // the monitor's record: every stamped sample the rig published
  std::map<std::string, MonitorTotals> monitor;
  std::map<std::string, std::uint64_t> counted_lost;  // units the rig counted lost in the window, by topic
  // Turns a LIDAR heard nothing in within the window (its `unheard`: lost or never made, a model
  // without numbering cannot tell; lidar/include/sensor_rig/lidar/stream_gap.hpp), by topic.
  std::map<std::string, std::uint64_t> unheard;
  std::map<std::string, TopicExpectation> expected;   // by topic
  // Vehicle-time intervals in which the rig flagged a topic's stamps unsynchronized (/diagnostics
  // stamp_sync): a stamp outside its bound then is the rig's own warning, not a lie.
  std::map<std::string, std::vector<std::pair<Nanos, Nanos>>> unsynchronized;
  FusedInput fused;
  // The drive-by-wire bridge under host.network_delay (its ECU's frames held): its /diagnostics
  // status dbw/bridge ("STATE (REASON)") as read, and the protocol's ecu_timeout_ms (0: not judged).
  std::vector<std::pair<Nanos, std::string>> dbw_bridge;
  Nanos dbw_ecu_timeout_ns = 0;
  // Gaps in the ECU feedback's alive counter across a silence with room for a whole counter turn,
  // which the bridge reports (dbw/vehicle_state gaps_unknown) instead of guessing k or k + a turn
  // (FrameLossCounter): each may hide frames lost next to the silence that its count lacks.
  std::uint64_t dbw_gaps_unknown = 0;
  Nanos window_begin_ns = 0;  // units are judged when their acquisition is in [begin, end)
  Nanos window_end_ns = 0;
  // How far the window of `counted_lost` may lie from [begin, end): the count is the difference of
  // two once-a-second monitor lines, each behind the losses it covers by up to the rig's diagnostics
  // period. Units not published within this of an edge may be in the count or not.
  Nanos count_edge_ns = 0;
  Bounds bounds;
};

struct TopicResult {
  std::string device;
  std::string device_class;
  std::uint64_t sent = 0;                  // units the device produced in the window
  std::uint64_t published_complete = 0;
  std::uint64_t published_incomplete = 0;  // published, its missing packets counted
  std::uint64_t counted_lost = 0;          // not published, counted lost by the rig
  std::uint64_t counted_unheard = 0;       // not published, lost whole in a silence the rig counted unheard
  std::uint64_t unaccounted = 0;           // neither published nor counted
  std::uint64_t phantom_missing = 0;       // packets counted missing that arrived intact
  std::uint64_t hidden_missing = 0;        // packets lost that the published unit does not count
  std::uint64_t published_twice = 0;       // a unit published more than once (a split scan)
  std::uint64_t unmatched = 0;             // published samples that match no unit the device made
  std::uint64_t stamps_outside = 0;        // stamp error beyond the bound, the topic not flagged
  std::uint64_t stamps_flagged = 0;        // beyond the bound while the rig flagged it unsynchronized
  std::uint64_t mixes_flagged = 0;         // fused sweeps regrouped by member stamps the rig flagged (mixing rotations, or whole without a scan of the true one)
  std::uint64_t mixes_regrouped = 0;       // fused sweeps one rotation by the boundary a rotation before or after (a LIDAR's phase moved), or by the boundary in a gap as wide (a tie)
  // |stamp - truth| over the judged samples. With fewer than 100 samples p99 is the largest but
  // one or the largest: a frame the host held is in it; the median is the stamps' body.
  double stamp_error_p50_ms = 0;
  double stamp_error_p99_ms = 0;
  double stamp_error_max_ms = 0;
  double healthy_rate_share = 1.0;         // delivered / expected while no fault touched the device
  double recovery_max_s = 0;
  std::uint64_t monitor_received = 0, monitor_lost = 0;  // its totals at the end (--json)
  std::uint64_t monitor_expected = 0;                    // units made while it watched
};

// Sets the topic's stamp error quantiles from its samples' errors (ms; sorted here).
void set_stamp_errors(TopicResult& t, std::vector<double>& errors_ms);

struct Example {
  std::string invariant;
  std::string topic;
  std::string what;
};

struct Result {
  std::map<std::string, TopicResult> topics;
  std::map<std::string, bool> invariants;  // name -> held
  std::vector<Example> examples;           // the first few per invariant
  std::map<std::string, std::uint64_t> faults;             // injected, by kind (from the truth records)
  std::map<std::string, std::uint64_t> faults_not_injected;  // planned, never recorded by a mock
  std::vector<std::string> campaign_errors;  // the rig did not stop, a process ended badly: no pass
  [[nodiscard]] bool all_held() const;
};

inline constexpr const char* kInvariants[] = {"accounted",      "no_phantom_loss", "stamps", "isolation", "recovery",
                                              "monitor_agrees", "faults_injected", "fused", "watchdog"};
inline constexpr const char* kFusedCloudTopic = "/sensors/lidar/fused/points";

Result check(const Input& in);

// The last --json line: {"faults":{..},"topics":{..},"invariants":{..}} (SPEC §7), plus examples.
std::string result_json(const Result& r);
// Human-readable: one line per invariant (held/broken with the first examples), a table per topic.
std::string result_text(const Result& r);

}  // namespace sensor_rig::rig::chaos
