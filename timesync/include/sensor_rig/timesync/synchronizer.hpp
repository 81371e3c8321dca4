#pragma once
// Synchronized sets: which samples of several topics belong together (as ROS message_filters'
// ExactTime / ApproximateTime policies), fed in any order across members, with missing, late and
// duplicate inputs. Pure: every time is an argument (stamp = header.stamp, arrival/now = the
// caller's clock), no I/O, no threads. See timesync/README.md "Synchronizer" for the algorithm.
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync {

enum class SyncPolicy : std::uint8_t {
  kExact,        // every member's header.stamp identical (max_spread is 0)
  kApproximate,  // one sample per member, smallest spread around a pivot, spread <= max_spread
};
const char* to_string(SyncPolicy p) noexcept;

struct SyncConfig {
  SyncPolicy policy = SyncPolicy::kApproximate;
  std::uint32_t members = 2;
  Nanos max_spread_ns = 10'000'000;   // approximate only: latest - earliest stamp of a set
  Nanos timeout_ns = 500'000'000;     // a pivot waits at most this long (arrival time) for the rest
  // Per member: the next sample's stamp is at least the last one's + this (ROS's inter-message
  // lower bound). 0 = unknown: a set is only final when every member has a sample at or after
  // the pivot (one period of latency); a bound lets it be final as soon as the members are in.
  std::vector<Nanos> min_interval_ns;  // empty = 0 for all
  std::size_t max_queue = 64;          // per member; the oldest sample goes when full
  // A stamp more than this beyond every stamp pushed so far is held until its member's next
  // sample: one at or after it confirms a step (both go in), an earlier one shows it was a wild
  // stamp (counted `implausible`, in no set). Queued, one future stamp became the pivot once its
  // member's normal samples were used, timed out and pinned the member (every sample before it
  // late) until vehicle time reached it. 0: the timeout.
  Nanos max_jump_ns = 0;
};

struct SyncSample {
  std::uint32_t member = 0;
  Nanos stamp_ns = 0;       // header.stamp
  std::uint64_t seq = 0;    // the sample's identity on its topic
  Nanos arrival_ns = 0;     // when the caller saw it (timeouts)
};

struct SyncSet {
  Nanos first_ns = 0;                // earliest member stamp
  Nanos spread_ns = 0;               // latest - earliest
  std::vector<SyncSample> samples;   // index = member
};

enum class PushResult : std::uint8_t {
  kAccepted,
  kLate,        // at or before the last stamp this member already gave to a decision
  kDuplicate,   // this member already holds a sample with this stamp
  kBadMember,
  kHeld,        // far beyond every stamp so far: waits for its member's next sample (max_jump_ns)
};

struct SyncStats {
  std::uint64_t pushed = 0;
  std::uint64_t sets = 0;
  std::uint64_t incomplete = 0;   // groups of samples that made no set (clusters within max_spread)
  std::uint64_t dropped = 0;      // samples in no set (skipped, unmatched, timed out, overflow)
  std::uint64_t late = 0;
  std::uint64_t duplicates = 0;
  std::uint64_t timeouts = 0;     // pivots decided by the timeout (complete or not)
  std::uint64_t overflows = 0;
  std::uint64_t implausible = 0;  // future stamps their member's next sample did not follow (also dropped)
  std::uint64_t jumps = 0;        // future stamps confirmed by the next sample: a step, followed
  std::vector<std::uint64_t> dropped_per_member;
};

class Synchronizer {
 public:
  explicit Synchronizer(SyncConfig cfg);  // throws std::invalid_argument

  PushResult push(const SyncSample& s, Nanos now_ns) noexcept;
  // Applies timeouts; call periodically (e.g. every 20 ms) when inputs may stop.
  void poll(Nanos now_ns) noexcept;
  // Completed sets, oldest first.
  bool pop(SyncSet& out) noexcept;
  [[nodiscard]] std::size_t ready() const noexcept { return ready_.size(); }
  [[nodiscard]] const SyncStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const SyncConfig& config() const noexcept { return cfg_; }

 private:
  struct Member {
    std::deque<SyncSample> queue;        // sorted by stamp
    Nanos watermark = kNone;             // latest stamp ever pushed
    Nanos consumed = kNone;              // latest stamp given to a decision
    std::optional<SyncSample> held;      // a stamp beyond max_jump_ns, until the next sample
  };
  static constexpr Nanos kNone = INT64_MIN;
  enum class Decision : std::uint8_t { kWait, kEmit, kDropPivot, kDropGroup };

  PushResult accept(const SyncSample& s, Nanos now_ns) noexcept;
  [[nodiscard]] bool beyond_every_stamp(Nanos stamp) const noexcept;
  void run(Nanos now_ns) noexcept;
  Decision decide(Nanos now_ns) noexcept;
  void drop(std::uint32_t m, const SyncSample& s) noexcept;
  void consume_through(std::uint32_t m, Nanos stamp) noexcept;  // drops everything before, takes == stamp

  SyncConfig cfg_;
  std::vector<Member> members_;
  std::deque<SyncSet> ready_;
  SyncStats stats_;
  // Scratch of decide(): the chosen sample per member (index into the queue), -1 = none.
  std::vector<std::ptrdiff_t> chosen_;
  std::uint32_t pivot_member_ = 0;
  Nanos recent_incomplete_[8] = {kNone, kNone, kNone, kNone, kNone, kNone, kNone, kNone};
  std::size_t recent_next_ = 0;
};

}  // namespace sensor_rig::timesync
