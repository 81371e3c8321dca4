#pragma once
// Which LIDAR scans make one sweep of the fused cloud. Pure: stamps and arrival times are
// arguments, no clock, no threads, no points (the node keeps those per sweep and source).
//
// Sweeps are matched by rotation, not by spread: the LIDARs turn at one period P (phase-locked,
// `max_spread_ms`), so each source's stamps keep one phase (stamp mod P). The sweep boundary lies in
// the middle of the widest gap between the sources' phases (a LIDAR above the rig's rpm, its scans
// short of a turn, has none while another source has one), and a scan belongs to the rotation
// floor((stamp - boundary) / P): the sweep whose scans lie closest together, whichever scan arrives
// first or late. A move of the boundary by about half a turn (a LIDAR back on a phase across the
// rig) goes the way that keeps the moved source's scan in the rotation the old boundary gave it. A
// clock step moves every source's phase alike: the boundary follows once each live
// source has shown it. A scan of a rotation whose sweep was emitted is late (dropped, counted); a
// second scan of one source in one rotation is dropped and counted too.
//
// A sweep is emitted (oldest first; emitting one emits every older open sweep before it) when each
// source is in, has moved on to a later sweep, or is dead; or `timeout_ns` after its first scan
// arrived. A source that a sweep waited for until the timeout is dead until it delivers again, so
// a stopped LIDAR costs one timeout and no later sweep waits for it. A source's stamps going back
// (a clock step back) start a new timeline: its scans are not late for that.
//
// A slower LIDAR (300 rpm beside 600 rpm: its scan spans k = 2 rotations of the period) is matched
// by its own rotation: its scan joins the sweep of the rotation it began in (its stamp, its first
// firing), and that sweep waits for it up to timeout + (k - 1) periods (the scan is handed over k
// periods after its stamp, not one). The sweeps of the rotations that scan also spans do not wait
// for it and lack nothing: it is `covered` there (its points for that time are in the sweep where its
// scan began; they say complete without it). A slow scan dropped as late covers nothing in the
// cloud: the sweeps it spans do not wait for that LIDAR, and lack it. k comes from the scan's span
// (its last point's time, rounded to whole periods); a scan that lacks part of its turn keeps the source's k while its
// stamps still step by k periods. Before, a 300 rpm LIDAR never made the fused cloud: every other
// sweep waited for it in vain, declared it dead, and its next scan came after its sweep was written.
//
// A scan short of its turn whose stamp is off its source's phase while its end lies where the
// source's turns end lost its head (a stuck encoder; the decoder stamps its first intact firing): it
// is placed as the turn it is the tail of. A source back after it was dead takes a phase jump as its
// own at once: a clock step meanwhile would have shown in the others' scans first.
//
// A scan whose stamps its LIDAR flagged (unsynchronized: slewing after a host clock step, no sync
// source) says nothing true about its phase: the boundary is placed by that source's last
// synchronized phase while it is flagged. Followed, the flagged stamps of two LIDARs slewing across
// the turn carried the boundary into a narrower gap (46.5 ms beside 52.5), where the quarter-gap rule
// kept it once they were back: 1,115 sweeps mixed rotations after the host clock steps of the
// ten-minute campaign, seed 3. A flagged source's phase jump (its mapping slewing, or back on its
// sync source) is its own at once, never held as a possible step of the vehicle clock.

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::drivers {

struct SweepMatcherConfig {
  std::uint32_t sources = 1;
  Nanos period_ns = 100'000'000;   // one rotation (600 rpm), the period every LIDAR is locked to
  Nanos timeout_ns = 150'000'000;  // arrival clock: a sweep waits at most this long after its first scan
};

struct SweepCounters {
  std::uint64_t sweeps = 0;  // emitted
  std::uint64_t complete = 0;
  std::uint64_t partial_timeout = 0;     // waited for a live source until the timeout
  std::uint64_t partial_dead = 0;        // every live source was in; the dead ones were not waited for
  std::uint64_t partial_next_sweep = 0;  // the missing sources moved on to a later sweep, or it was emitted
  std::uint64_t late_scans = 0;          // their rotation's sweep was already emitted
  std::uint64_t repeated_scans = 0;      // a second scan of one source in one rotation
  std::uint64_t clock_steps_back = 0;    // a source's stamps went back (a new timeline)
  std::uint64_t phase_steps = 0;         // a source's phase jumped (a clock step, or its own phase changed)
  std::uint64_t covered = 0;             // sources absent from a sweep whose rotation their last (slower) scan spans
  std::uint64_t head_lost_scans = 0;     // placed where their turn began: short of it, their stamp off the phase, their end on it or inside that turn
  std::uint64_t unsynchronized_scans = 0;  // their LIDAR flagged their stamps: their phase did not place the boundary
  std::uint64_t resynchronized = 0;        // a source's stamps synchronized again (its phase places the boundary again)
  std::vector<std::uint64_t> missing;    // per source: emitted sweeps without its scan
};

// A sweep to emit: the scans pushed with this id, in the order they came.
struct ClosedSweep {
  std::uint64_t id = 0;
  bool complete = false;      // every source present or covered
  std::vector<bool> present;  // per source
  std::vector<bool> covered;  // per source: absent, its scan in an earlier sweep spans this rotation (not missing)
};

class SweepMatcher {
 public:
  explicit SweepMatcher(const SweepMatcherConfig& cfg);  // throws std::invalid_argument

  struct Placement {
    bool late = false;        // dropped: late, repeated or an unknown source
    std::uint64_t sweep = 0;  // else: the sweep it joined (ClosedSweep::id)
  };
  // `arrival_ns` on a clock that does not step (monotonic); `span_ns` the scan's duration (its last
  // point's time after its stamp; 0 = unknown: one period). `unsynchronized`: its LIDAR flagged the
  // scan's stamp. Then call ready() until it returns none.
  Placement push(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns, Nanos span_ns = 0, bool unsynchronized = false);
  // The next sweep to emit now, oldest first, or none.
  std::optional<ClosedSweep> ready(Nanos now_ns);
  // Arrival deadline of the oldest open sweep (call ready() then), or -1 when none is open.
  [[nodiscard]] Nanos deadline() const noexcept;
  [[nodiscard]] std::size_t open_sweeps() const noexcept { return open_.size(); }
  [[nodiscard]] const SweepCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const SweepMatcherConfig& config() const noexcept { return cfg_; }

  // At most this many sweeps are open at once; a further one emits the oldest (node buffers are finite).
  static constexpr std::size_t kMaxOpen = 4;

 private:
  struct Source {
    bool seen = false;
    bool alive = true;  // until a sweep waited for it in vain
    Nanos last_stamp = 0;
    Nanos last_arrival = 0;
    Nanos last_span = 0;  // of its last scan (0: not told)
    Nanos phase = 0;   // last stamp mod period
    Nanos offset = 0;  // its timeline stepped by this, not yet every live source's ([-P, P): the sign is the rotation)
    int offset_scans = 0;
    Nanos jumped_at = 0;  // arrival of the scan whose step set the offset
    std::uint64_t last_sweep = 0;  // id of the sweep its last scan joined (0: none)
    int rotations = 1;             // periods one of its scans spans (2: a 300 rpm LIDAR beside 600 rpm)
    std::int64_t last_rotation = 0;   // rotation of its newest scan
    std::int64_t covers_until = 0;    // that scan spans the rotations before this one (exclusive)
    bool short_turn = false;          // that scan ended short of its k periods (see settled())
    bool newest_placed = true;        // that scan joined a sweep (dropped as late it covers nothing in the cloud)
    bool above_rpm = false;           // its scans are short of a turn and follow by less (1200 rpm beside 600)
    bool flagged = false;             // its newest scan's stamp was flagged unsynchronized
    bool synced_once = false;         // it has had a synchronized scan
    Nanos sync_phase = 0;             // its last synchronized scan's phase, in the boundary's timeline
  };
  struct Sweep {
    std::uint64_t id = 0;
    std::int64_t rotation = 0;
    Nanos opened_at = 0;
    std::vector<bool> present;
    std::uint32_t count = 0;
  };

  [[nodiscard]] std::int64_t rotation_of(const Source& src, Nanos stamp) const noexcept;
  // own_mapping: the source's stamps are flagged (this scan's or the one before): a jump is its own.
  void track_phase(Source& src, Nanos stamp, Nanos arrival, Nanos span, bool returning, bool own_mapping);
  [[nodiscard]] Nanos head_lost_turn_began(const Source& src, Nanos stamp, Nanos span) const noexcept;
  [[nodiscard]] Nanos timeline_step(const Source& src, Nanos stamp, Nanos arrival, Nanos span) const noexcept;
  void place_boundary(bool anew, const Source* moved = nullptr);  // moved: the source whose phase moved it
  [[nodiscard]] Nanos boundary_phase(const Source& s) const noexcept;  // the phase the boundary is placed by
  [[nodiscard]] bool step_refuted(const Source& moved) const noexcept;
  [[nodiscard]] bool settled(const Sweep& s) const noexcept;
  [[nodiscard]] bool covered(std::size_t source, const Sweep& s) const noexcept;
  [[nodiscard]] bool covered_in_cloud(std::size_t source, const Sweep& s) const noexcept;  // by a scan that joined a sweep
  [[nodiscard]] Nanos wait_ns(const Sweep& s) const noexcept;  // timeout + a slower absent source's extra periods
  [[nodiscard]] bool whole(const Sweep& s) const noexcept;     // every source present or covered
  static constexpr int kMaxRotations = 4;  // 150 rpm beside 600
  ClosedSweep close_front(std::uint64_t& reason);

  SweepMatcherConfig cfg_;
  SweepCounters counters_;
  std::vector<Source> sources_;
  std::deque<Sweep> open_;            // by creation (= id) order
  std::deque<std::int64_t> emitted_;  // rotations of the last emitted sweeps (late scans are told by them)
  Nanos boundary_ = 0;                // its phase mod period; moves continuously (never wrapped)
  bool boundary_set_ = false;
  std::uint64_t next_id_ = 1;
};

}  // namespace sensor_rig::drivers
