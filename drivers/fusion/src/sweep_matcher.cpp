#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::drivers {
namespace {

// a - b on the circle of one period, in [-p/2, p/2).
Nanos signed_circular(Nanos d, Nanos p) noexcept { return floor_mod(d + p / 2, p) - p / 2; }

// In [-2p, 2p) reduced to [-p, p): an offset keeps its sign, which says the rotation a step went to.
Nanos wrap_offset(Nanos d, Nanos p) noexcept { return floor_mod(d + p, 2 * p) - p; }

Nanos circular_distance(Nanos a, Nanos b, Nanos p) noexcept {
  const Nanos d = floor_mod(a - b, p);
  return std::min(d, p - d);
}

// How many emitted rotations are remembered to tell a late scan (the node queues at most a few).
constexpr std::size_t kEmittedRemembered = 16;
// A source whose phase moved alone for this many scans changed its own phase (a restarted,
// free-running sensor), not with the clock: the boundary is placed anew.
constexpr int kOwnPhaseScans = 3;

}  // namespace

SweepMatcher::SweepMatcher(const SweepMatcherConfig& cfg) : cfg_(cfg) {
  if (cfg_.sources == 0) throw std::invalid_argument("sweep matcher: no sources");
  if (cfg_.period_ns <= 0 || cfg_.timeout_ns <= 0)
    throw std::invalid_argument("sweep matcher: period and timeout must be > 0");
  sources_.resize(cfg_.sources);
  counters_.missing.assign(cfg_.sources, 0);
}

std::int64_t SweepMatcher::rotation_of(const Source& src, Nanos stamp) const noexcept {
  return floor_div(stamp - boundary_ - src.offset, cfg_.period_ns);
}

// A phase that jumps by more than an eighth of a rotation is a step of the source's timeline. A step
// of the vehicle clock reaches the sources one scan after another: until every live source has
// shown it, the ones that stepped keep their offset (their scans then match each other's, never
// an unstepped scan of another rotation); then the boundary moves by the step.
void SweepMatcher::track_phase(Source& src, Nanos stamp, Nanos arrival, Nanos span, bool returning, bool own_mapping) {
  const Nanos p = cfg_.period_ns, tolerance = p / 8;
  const Nanos phase = floor_mod(stamp, p);
  if (!src.seen) {
    src = Source{.seen = true, .alive = true, .last_stamp = stamp, .last_arrival = arrival, .last_span = span, .phase = phase};
    return;
  }
  const Nanos jump = timeline_step(src, stamp, arrival, span);
  // What the arrivals do not explain of the stamps' advance: a scan is handed over at its end, so
  // the arrivals advance as the stamps do plus the change of span. A step of the clock moves the
  // stamps alone; a move of the source's own (a new rpm: the mock's rotor, a real one's motor,
  // cutting a turn short) moves both.
  const auto turn = [&](Nanos s) { return s > 0 ? s : p; };
  const Nanos unexplained = (stamp - src.last_stamp) + (turn(span) - turn(src.last_span)) - (arrival - src.last_arrival);
  src.phase = phase;
  src.last_arrival = arrival;
  src.last_span = span;
  if (std::abs(jump) > tolerance) {
    ++counters_.phase_steps;
    const bool none_pending = std::all_of(sources_.begin(), sources_.end(), [](const Source& s) { return s.offset == 0; });
    if ((std::abs(unexplained) <= tolerance || returning || own_mapping) && none_pending) {
      // Its own phase, told by the arrivals at once: the boundary is placed anew now. Held as a
      // possible clock step, the scans of the whole-rig campaign's front LIDAR returning from
      // 300 to 600 rpm (a turn cut to 165 ms) were fused with the rotation before their own.
      // Or back after it was dead (a restart, a kill): a step of the clock meanwhile would have
      // shown in the others' scans first (none is pending), and across the gap its arrivals say
      // nothing. Held as a possible step, a front LIDAR killed for a second and back 61 ms later in
      // the rotation had its first scan fused with the next rotation (ten-minute campaign, seed 2).
      // Or its stamps are flagged, this scan's or the one before: they move with the LIDAR's own
      // mapping (slewing, or back on its sync source), not with the vehicle clock, whose step the
      // others would show. Held as a possible step, the left and right LIDARs' stamps stepping back
      // 85 ms to their truth after a network hold kept the held timeline for three scans: three
      // sweeps fused them with the front's next turn (ten-minute campaign, seed 9, 198.9 s).
      place_boundary(true, &src);
      return;
    }
    src.offset = wrap_offset(src.offset + jump, p);
    src.offset_scans = 0;
    src.jumped_at = arrival;
    if (std::abs(signed_circular(src.offset, p)) <= tolerance) src.offset = 0;  // caught up with a step the others made
  }
  if (src.offset != 0) {
    const Nanos step = src.offset;
    bool everyone = true;
    for (const auto& s : sources_)
      if (s.seen && s.alive && std::abs(signed_circular(s.offset - step, p)) > tolerance) everyone = false;
    if (everyone) {
      boundary_ += step;  // not wrapped into [0, p): see place_boundary
      for (auto& s : sources_) {
        s.sync_phase = floor_mod(s.sync_phase + step, p);  // the same phase in the stepped timeline
        s.offset = signed_circular(s.offset - step, p);  // a dead source has yet to show the step
        if (std::abs(s.offset) <= tolerance) s.offset = 0;
      }
    } else if (++src.offset_scans > kOwnPhaseScans || step_refuted(src)) {
      for (auto& s : sources_) s.offset = 0;
      place_boundary(true, &src);
      return;
    }
  }
  // Another source's scan may be the one that refutes a pending step: on every scan, an unmoved
  // one's above all (it is the witness). Checked only on scans of a moved source, the front LIDAR's
  // restart was held as a step until its own next scan, which mixed a second rotation (LIDAR-fault
  // campaign seed 3, 157.2 s: replayed through the matcher from the monitor's record).
  for (const auto& s : sources_) {
    if (&s == &src || s.offset == 0 || !step_refuted(s)) continue;
    for (auto& o : sources_) o.offset = 0;
    place_boundary(true, &s);
    return;
  }
}

// Where the turn began that a scan is the tail of, when its head was lost: a scan short of its turn
// (one rotation, the rig's rpm) whose stamp is off the source's phase while its end lies where a
// whole turn from the phase ends, or lies wholly inside a turn from the phase. Else its stamp.
Nanos SweepMatcher::head_lost_turn_began(const Source& src, Nanos stamp, Nanos span) const noexcept {
  const Nanos p = cfg_.period_ns, tolerance = p / 8;
  if (!src.seen || src.rotations != 1 || src.above_rpm || src.offset != 0 || span <= 0 || span >= p - p / 4) return stamp;
  // The source's whole turn: its last scan's span where that was one (a scan cut short by the
  // freeze, 92 ms, put the began end 8 ms off, as far as its stamp: seq 77 of a 30 s campaign of
  // left-LIDAR freezes, fused with the next turn).
  const Nanos turn = src.last_span >= p - p / 32 && src.last_span <= p + p / 8 ? src.last_span : p;
  const Nanos began = stamp + span - turn;
  // Its stamp is past the start of the turn after its predecessor's: scans above the rig's rpm
  // (following each other by half a turn) and a clock step back are not this.
  if (stamp - src.last_stamp < p + tolerance) return stamp;
  // The end nearer the phase says which turn it is: its stamp (its tail lost) or its end (its head
  // lost). Its stamp within P/8 of the phase was taken for "on it": a scan of which only the last
  // 8 ms survived a stuck encoder was stamped 8 ms before the next turn and fused with that turn's
  // scans (ten-minute campaign, seed 4, the left LIDAR at 358.6 s).
  const Nanos stamp_off = std::abs(signed_circular(stamp - src.phase, p));
  const Nanos began_off = std::abs(signed_circular(began - src.phase, p));
  if (began_off <= tolerance && stamp_off > began_off) return began;
  // Head and tail lost: a scan that lies inside one turn from the phase, off it at both ends (a
  // blind sector across the cut: a VLP-32C seeing only 272-301 deg sends scans of 8 ms stamped
  // 75 ms into their turn, fused with the others' next rotation: rig chaos seed 9 with drawn
  // parameters, 179 sweeps). Its turn began on the phase before its stamp.
  const Nanos into = floor_mod(stamp - src.phase, p);
  if (into > tolerance && into + span <= p + tolerance) return stamp - into;
  return stamp;
}

// A step of the vehicle clock shows in every source's scans that begin after it. The moved source's
// step happened before its scan began (at the latest a turn before its arrival); once another live
// source has handed over a scan that began after that, unmoved (and none has moved), the step was
// the moved source's own (a restart, a stall, a new rpm): its phase is taken at once, not after
// kOwnPhaseScans of its scans, which mixed rotations meanwhile (a 300 rpm LIDAR's 3 scans are 600 ms).
// One such witness is proof: a step before its scan began would show in it. (Waiting for every
// source to be one held a restarted front LIDAR's move as a step until its next scan had mixed a
// second rotation: LIDAR-fault campaign seed 3, 157.2 s, the right LIDAR's witness 7 ms too late.)
// A quarter period of margin for the difference of the scans' delivery delays (28.8 ms the most
// seen under a loaded suite run); a scan taken as a witness wrongly costs what the wait did.
bool SweepMatcher::step_refuted(const Source& moved) const noexcept {
  const Nanos p = cfg_.period_ns;
  const Nanos moved_began_by = moved.jumped_at - p + p / 4;
  bool witness = false;
  for (const auto& s : sources_) {
    if (&s == &moved || !s.seen || !s.alive) continue;
    if (s.offset != 0) return false;  // another source moved too: maybe the clock
    const Nanos turn = s.last_span > 0 ? s.last_span : p;
    if (s.last_arrival - turn > moved_began_by) witness = true;
  }
  return witness;
}

// How far the source's timeline stepped since its last scan. The phase says it only modulo P, and a
// step near P/2 reads +P/2 or -P/2 by a few microseconds: the two put the scan in rotations one
// apart (the stamps of a PTP LIDAR slewed 50 ms late snapping back: that LIDAR's next scan fused
// with the others' rotation N+1 and called complete, the one before it dropped as late). Of the
// two readings, one may be impossible: a scan never begins before its predecessor's turn is over.
// When both are possible, the arrival clock (it does not step) tells them apart: a scan is handed
// over at its end, the periods that passed after its predecessor's, so the reading whose stamp
// advance is clearly nearer the arrival advance wins; else the phase's own. Scans shorter than a
// turn (a LIDAR above the rig's rpm) follow each other by less than a period: the phase's stands.
Nanos SweepMatcher::timeline_step(const Source& src, Nanos stamp, Nanos arrival, Nanos span) const noexcept {
  const Nanos p = cfg_.period_ns, slack = p / 8;
  const Nanos advance = stamp - src.last_stamp, elapsed = arrival - src.last_arrival;
  const Nanos by_phase = signed_circular(advance, p);
  const auto short_of_a_turn = [&](Nanos s) { return s > 0 && s < p - 2 * slack; };
  if (std::abs(by_phase) <= slack || short_of_a_turn(span) || short_of_a_turn(src.last_span)) return by_phase;
  const Nanos other = by_phase > 0 ? by_phase - p : by_phase + p;
  const auto possible = [&](Nanos step) { return advance - step >= p - slack; };
  // A scan is handed over at its end: a longer one (a slower LIDAR's) later by the difference.
  const auto turn = [&](Nanos s) { return s > 0 ? s : p; };
  const Nanos longer = turn(span) - turn(src.last_span);
  const auto error = [&](Nanos step) { return std::abs(advance - step + longer - elapsed); };
  if (!possible(other)) return by_phase;
  if (!possible(by_phase)) return other;
  return error(other) <= p / 4 && error(other) + slack < error(by_phase) ? other : by_phase;
}

// The boundary goes into the middle of the widest gap between the sources' phases. It stays where it
// is while no phase comes near it (within a quarter of that gap): phases that jitter across two
// nearly equal gaps must not move it back and forth, since moving it renumbers rotations.
// A source above the rig's rpm (Source::above_rpm) has no phase at the rig's period: its scans begin
// half a turn apart. Counted, its phase flipped the widest gap with every scan, and the boundary with
// it, across another LIDAR's phase (the ten-minute campaign, seed 1: 373 sweeps mixed rotations
// while the right LIDAR ran at 1200 rpm). Its phase counts only where every source is such (one rpm
// for all: the boundary is theirs).
// A source whose stamps are flagged is placed by its last synchronized phase (one never
// synchronized, by what it has).
Nanos SweepMatcher::boundary_phase(const Source& s) const noexcept {
  if (s.flagged && s.synced_once) return s.sync_phase;
  return floor_mod(s.phase - s.offset, cfg_.period_ns);  // in the boundary's timeline
}

void SweepMatcher::place_boundary(bool anew, const Source* moved) {
  const Nanos p = cfg_.period_ns;
  const bool any_at_rpm = std::any_of(sources_.begin(), sources_.end(), [](const Source& s) { return s.seen && !s.above_rpm; });
  std::vector<Nanos> phases;
  for (const auto& s : sources_)
    if (s.seen && (!any_at_rpm || !s.above_rpm)) phases.push_back(boundary_phase(s));
  if (phases.empty()) return;
  std::sort(phases.begin(), phases.end());
  Nanos widest = -1, middle = 0;
  for (std::size_t i = 0; i < phases.size(); ++i) {
    const Nanos next = i + 1 < phases.size() ? phases[i + 1] : phases[0] + p;
    if (next - phases[i] > widest) {
      widest = next - phases[i];
      middle = floor_mod(phases[i] + widest / 2, p);
    }
  }
  Nanos nearest = p;
  for (const Nanos ph : phases) nearest = std::min(nearest, circular_distance(boundary_, ph, p));
  // The boundary moves the short way round and is never wrapped back into [0, p): rotation numbers
  // count periods from it, so a boundary stored wrapped (moved from 90 to 112.5 ms, kept as 12.5)
  // renumbers every rotation by one. The scans already placed kept the old numbers: the rig's
  // first sweep split, and a scan after such a move could be taken for a late one.
  if (!boundary_set_) {
    boundary_ = middle;
    boundary_set_ = true;
  } else if (anew || nearest < widest / 4) {
    Nanos move = signed_circular(middle - boundary_, p);
    // Near half a turn either way round is the short one by the rounding of the phases, and the
    // two number the sources on one side of the boundary a rotation apart. A source that moved
    // keeps the number the old boundary gives its new scan (the one that groups it with the others'
    // scans of its own turn): moved across its new phase, the front LIDAR back from 300 rpm on the
    // left's phase had its first two scans fused with the turn before (ten-minute campaign, seed 4).
    if (moved != nullptr && std::abs(move) > p / 2 - p / 8) {
      const Nanos ph = boundary_phase(*moved);
      const Nanos into = move > 0 ? floor_mod(ph - boundary_, p) : floor_mod(boundary_ - ph, p);
      if (into > 0 && into < std::abs(move)) move += move > 0 ? -p : p;
    }
    boundary_ += move;
  }
}

SweepMatcher::Placement SweepMatcher::push(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns, Nanos span_ns, bool unsynchronized) {
  Placement out;
  if (source >= cfg_.sources) {
    ++counters_.late_scans;
    out.late = true;
    return out;
  }
  auto& src = sources_[source];
  const bool returning = src.seen && !src.alive;  // a sweep waited for it in vain: stopped, killed, restarted
  src.alive = true;  // delivering, even if this scan comes too late
  const Nanos p = cfg_.period_ns;
  // A scan short of its turn that ends where the source's turns end, its stamp off the source's
  // phase, lost its head (a stuck encoder, packets lost at the start: the decoder stamps its first
  // intact firing): it is the tail of the turn that began on the phase, and is placed as that turn.
  // By its stamp it joined the next rotation (ten-minute campaign, seed 2: the left LIDAR's first
  // scan after a lidar.stuck_azimuth, 16 of 64 packets stamped 75 ms into its turn, fused with the
  // others' next rotation).
  if (const Nanos began = head_lost_turn_began(src, stamp_ns, span_ns); began != stamp_ns) {
    span_ns = stamp_ns + span_ns - began;
    stamp_ns = began;
    ++counters_.head_lost_scans;
  }
  // The periods this scan spans (k). Its span must be a whole number of periods (within P/8, at
  // most kMaxRotations) and its stamp step from the source's previous scan agree: k periods, or
  // one period where the source just slowed down. A span that is neither (a clock step inside the
  // scan: the campaign's -500 ms host steps made 600 ms spans) says nothing. A scan short of its
  // turn (lost packets) keeps the source's k while its stamps step by that many periods.
  const Nanos delta = src.seen ? stamp_ns - src.last_stamp : -1;
  const auto near = [&](Nanos a, Nanos b, Nanos tol) { return std::abs(a - b) <= tol; };
  const Nanos whole = span_ns > 0 ? (span_ns + p / 2) / p : 0;
  int k = 1;
  if (whole >= 2 && whole <= kMaxRotations && near(span_ns, whole * p, p / 8) &&
      (delta < 0 || near(delta, whole * p, p / 4) || (src.rotations == 1 && near(delta, p, p / 4))))
    k = static_cast<int>(whole);
  else if (src.seen && src.rotations > 1 && near(delta, src.rotations * p, p / 4) && (whole == 0 || whole <= src.rotations))
    k = src.rotations;
  const bool newest = !src.seen || stamp_ns > src.last_stamp;
  // A source's scans come in order: stamps that go back mean its clock stepped back, and the
  // rotations emitted on the old timeline say nothing about the new one.
  if (src.seen && stamp_ns < src.last_stamp - cfg_.period_ns / 2) {
    ++counters_.clock_steps_back;
    emitted_.clear();
  }
  // Above the rig's rpm: scans short of three quarters of a turn that follow each other by less. A
  // scan short of its turn alone (its last packets lost, a turn cut by a restart) comes a whole
  // period after the one before: the source keeps its phase (left out, the boundary could move
  // across it, and that scan join the next rotation). One at the rig's rpm or slower ends it.
  const bool short_of_a_turn = span_ns > 0 && span_ns < p - p / 4;
  if (!short_of_a_turn) src.above_rpm = false;
  else if (delta > 0 && delta < p - p / 4) src.above_rpm = true;
  // The phase first, so that a source's first scan never lies on the boundary. A flagged scan's phase
  // places nothing: the boundary keeps the source's last synchronized one, which its synchronized
  // stamps come back to. (Placed anew when they did, the boundary could move by the jitter of the
  // phases and split a sweep; a phase that really changed meanwhile is a move, taken as any is.)
  const bool resynchronized = src.seen && src.flagged && !unsynchronized;
  const bool own_mapping = src.seen && (src.flagged || unsynchronized);
  src.flagged = unsynchronized;
  track_phase(src, stamp_ns, arrival_ns, span_ns, returning, own_mapping);
  src.flagged = unsynchronized;  // (a source's first scan made its state anew)
  if (unsynchronized) {
    ++counters_.unsynchronized_scans;
  } else {
    src.sync_phase = floor_mod(src.phase - src.offset, p);
    src.synced_once = true;
  }
  if (resynchronized) ++counters_.resynchronized;
  place_boundary(false);
  const std::int64_t rotation = rotation_of(src, stamp_ns);
  src.last_stamp = stamp_ns;
  if (newest) {
    src.rotations = k;
    src.last_rotation = rotation;
    src.covers_until = std::max(rotation + 1, rotation_of(src, stamp_ns + k * p));
    src.short_turn = k > 1 && span_ns > 0 && span_ns < k * p - p / 8;
    src.newest_placed = false;  // until it joins a sweep below
  }
  if (std::find(emitted_.begin(), emitted_.end(), rotation) != emitted_.end()) {
    ++counters_.late_scans;
    out.late = true;
    return out;
  }
  auto it = std::find_if(open_.begin(), open_.end(), [&](const Sweep& s) { return s.rotation == rotation; });
  if (it != open_.end() && it->present[source]) {
    ++counters_.repeated_scans;
    out.late = true;
    return out;
  }
  if (it == open_.end()) {
    Sweep s;
    s.id = next_id_++;
    s.rotation = rotation;
    s.opened_at = arrival_ns;
    s.present.assign(cfg_.sources, false);
    open_.push_back(std::move(s));
    it = std::prev(open_.end());
  }
  it->present[source] = true;
  ++it->count;
  if (newest) src.newest_placed = true;
  src.last_sweep = it->id;
  out.sweep = it->id;
  return out;
}

// A source absent from sweep `s` whose newest scan began in an earlier rotation and spans this one.
bool SweepMatcher::covered(std::size_t i, const Sweep& s) const noexcept {
  const Source& src = sources_[i];
  return !s.present[i] && src.seen && src.rotations > 1 && src.last_rotation < s.rotation && s.rotation < src.covers_until;
}

// Covered by a scan the cloud has: one dropped as late (a LIDAR's first slow scan after its sweep
// timed out) still says no more of that time will come (the sweeps it spans do not wait), but its
// points are in no sweep, and a sweep it spans lacks them (before: said complete, the whole-rig
// campaign's fused judge, "complete with 2 of 3").
bool SweepMatcher::covered_in_cloud(std::size_t i, const Sweep& s) const noexcept {
  return covered(i, s) && sources_[i].newest_placed;
}

bool SweepMatcher::whole(const Sweep& s) const noexcept {
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (!s.present[i] && !covered_in_cloud(i, s)) return false;
  return true;
}

// Nothing more to wait for: each source is in, covered, has moved on to a later sweep, or is dead.
// A slow scan that ended short of its turns covers the rotations after it only until the source's
// next scan says where it began: its last packets lost (the next one begins k periods on: covered),
// or its turn cut short (a LIDAR back to the rig's rpm: the next one begins in the covered rotation
// and belongs there). Until then, or the timeout, that sweep waits for it. Before, it went out at
// once saying complete without that LIDAR, whose next scan then came late for it (the whole-rig
// campaign, seed 25, front at 19.05 s).
bool SweepMatcher::settled(const Sweep& s) const noexcept {
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (!s.present[i] && sources_[i].alive && sources_[i].last_sweep <= s.id && (!covered(i, s) || sources_[i].short_turn))
      return false;
  return true;
}

// A slower source's scan is handed over (k - 1) periods after a one-period source's of its rotation.
Nanos SweepMatcher::wait_ns(const Sweep& s) const noexcept {
  int k = 1;
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (!s.present[i] && sources_[i].alive && sources_[i].last_sweep <= s.id && !covered(i, s)) k = std::max(k, sources_[i].rotations);
  return cfg_.timeout_ns + (k - 1) * cfg_.period_ns;
}

ClosedSweep SweepMatcher::close_front(std::uint64_t& reason) {
  std::vector<bool> cov(cfg_.sources, false);
  for (std::size_t i = 0; i < cov.size(); ++i) cov[i] = covered_in_cloud(i, open_.front());
  Sweep s = std::move(open_.front());
  open_.pop_front();
  ++counters_.sweeps;
  ++reason;
  bool complete = true;
  for (std::size_t i = 0; i < s.present.size(); ++i) {
    if (cov[i]) ++counters_.covered;
    else if (!s.present[i]) {
      ++counters_.missing[i];
      complete = false;
    }
  }
  emitted_.push_back(s.rotation);
  if (emitted_.size() > kEmittedRemembered) emitted_.pop_front();
  return ClosedSweep{s.id, complete, std::move(s.present), std::move(cov)};
}

std::optional<ClosedSweep> SweepMatcher::ready(Nanos now_ns) {
  if (open_.empty()) return std::nullopt;
  const auto timed_out = [&](const Sweep& s) { return now_ns - s.opened_at >= wait_ns(s); };
  // The newest sweep that may go out; every older one goes out before it.
  bool any = open_.size() > kMaxOpen;
  for (auto it = open_.rbegin(); !any && it != open_.rend(); ++it) any = settled(*it) || timed_out(*it);
  if (!any) return std::nullopt;
  const Sweep& f = open_.front();
  if (whole(f)) return close_front(counters_.complete);
  if (!settled(f) && timed_out(f)) {
    for (std::size_t i = 0; i < sources_.size(); ++i)  // waited for in vain: not waited for again
      if (!f.present[i] && sources_[i].last_sweep <= f.id) sources_[i].alive = false;
    return close_front(counters_.partial_timeout);
  }
  bool moved_on = !settled(f);  // forced out by a newer sweep
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (!f.present[i] && sources_[i].last_sweep > f.id) moved_on = true;
  return close_front(moved_on ? counters_.partial_next_sweep : counters_.partial_dead);
}

Nanos SweepMatcher::deadline() const noexcept { return open_.empty() ? -1 : open_.front().opened_at + wait_ns(open_.front()); }

}  // namespace sensor_rig::drivers
