#pragma once
// Packet-to-packet continuity of spinning sensors that stamp each firing group with its azimuth
// (Velodyne, Hesai): which groups of a packet have an implausible azimuth (corrupted: dropped, not
// a scan cut), and how many packets are missing between two packets (from the azimuth step, the
// sensor's own time step and the configured field of view). Pure integer/double arithmetic on a
// dozen values per packet; inline because it runs once per packet inside the decoders' hot path
// (see scan_assembler.hpp for why those stay visible to the compiler).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"

namespace sensor_rig::lidar::detail {

inline constexpr int kTurn = 36000;  // hundredths of a degree

// Forward step from a to b in [0, kTurn); a and b in [0, kTurn).
constexpr int turn_step(int a, int b) noexcept {
  const int d = b - a;
  return d < 0 ? d + kTurn : d;
}
constexpr int wrap_turn(int a) noexcept {  // any int -> [0, kTurn)
  const int r = a % kTurn;
  return r < 0 ? r + kTurn : r;
}
constexpr int turn_dist(int a, int b) noexcept {  // shortest distance, either way
  const int s = turn_step(a, b);
  return s > kTurn / 2 ? kTurn - s : s;
}

// The azimuth range a sensor sends (its own FOV setting), clockwise from `start` to `end`, in
// hundredths of a degree; `full` = the whole turn.
struct AzimuthFov {
  int start = 0;
  int end = 0;
  bool full = true;
  [[nodiscard]] int length() const noexcept { return full ? kTurn : (turn_step(start, end) == 0 ? kTurn : turn_step(start, end)); }
};

// Degrees -> AzimuthFov; start == end (or both 0 / 360) is the full turn.
inline AzimuthFov make_fov(double start_deg, double end_deg) noexcept {
  const int s = static_cast<int>(std::lround(start_deg * 100.0)) % kTurn;
  const int e = static_cast<int>(std::lround(end_deg * 100.0)) % kTurn;
  return s == e ? AzimuthFov{} : AzimuthFov{s, e, false};
}

// Length of the part of the arc (from, from + len] that lies outside the FOV.
inline int arc_outside(const AzimuthFov& fov, int from, int len) noexcept {
  if (fov.full || len <= 0) return 0;
  const int q = fov.end;                     // the blind arc: [end, end + blind)
  const int blind = kTurn - fov.length();
  int total = 0;
  const int p = ((from % kTurn) + kTurn) % kTurn;
  for (int shift = -kTurn; shift <= kTurn; shift += kTurn) {
    const int lo = std::max(p, q + shift);
    const int hi = std::min(p + len, q + shift + blind);
    if (hi > lo) total += hi - lo;
  }
  return std::min(total, len);
}

// How far a group's azimuth may be off the packet's line (jitter of real sensors: a few 0.01°).
constexpr int fit_tolerance(int step) noexcept { return 5 + std::abs(step) / 4; }

// The azimuths of one packet's firing groups against a straight line.
struct AzimuthFit {
  double step = 0.0;       // azimuth advance per group, 0.01°
  std::uint32_t bad = 0;   // bit k: group k is off the line (corrupted azimuth)
  int good = 0;            // groups on the line
};

// `az`: the n (<= 32) group azimuths, already reduced to [0, kTurn).
inline AzimuthFit fit_azimuths(const int* az, int n) noexcept {
  AzimuthFit f;
  f.good = n;
  if (n < 2) return f;
  int lo = kTurn, hi = 0;
  for (int k = 1; k < n; ++k) {
    const int s = turn_step(az[k - 1], az[k]);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  if (hi - lo <= fit_tolerance(hi) && hi < kTurn / 8) {  // the common case: one straight line
    f.step = static_cast<double>(turn_step(az[0], az[n - 1])) / (n - 1);
    return f;
  }
  // Lower median step (a corrupted azimuth makes two steps, both long: into it and out of it),
  // then the line through the most groups; the others are off it.
  int steps[32];
  for (int k = 1; k < n; ++k) steps[k - 1] = turn_step(az[k - 1], az[k]);
  const int mid = (n - 2) / 2;
  std::nth_element(steps, steps + mid, steps + (n - 1));
  const int med = steps[mid] >= kTurn / 2 ? 0 : steps[mid];
  const int tol = fit_tolerance(med);
  int best = 0, best_count = 0;
  for (int k = 0; k < n; ++k) {
    const int ok = wrap_turn(az[k] - k * med);
    int c = 0;
    for (int j = 0; j < n; ++j) c += turn_dist(ok, wrap_turn(az[j] - j * med)) <= tol ? 1 : 0;
    if (c > best_count) {
      best_count = c;
      best = k;
    }
  }
  const int ref = wrap_turn(az[best] - best * med);
  f.good = 0;
  for (int k = 0; k < n; ++k) {
    if (turn_dist(ref, wrap_turn(az[k] - k * med)) <= tol) {
      ++f.good;
    } else {
      f.bad |= 1U << k;
    }
  }
  f.step = med;
  return f;
}

// How far back (in packets) a packet may step and still be a duplicate or a reordered one.
inline constexpr int kReorderPackets = 16;

// The step from the previous packet's last good group to this packet's first good group.
struct GapInput {
  int prev_az = 0;             // last good group azimuth of the previous packet
  int groups_since_prev = 1;   // groups from that one to this packet's first good group, if none is lost
  int first_az = 0;            // this packet's first good group azimuth
  double group_step = 0.0;     // azimuth per group (AzimuthFit::step)
  int groups_per_packet = 1;
  Nanos dt_ns = 0;             // sensor time step between the packets (0 or less: unknown / none)
  Nanos packet_period_ns = 0;  // sensor time per packet
  // The packet's own time lies behind the previous packet's by more than the reorder window but
  // less than half a turn (old_packet()): sent before it, however far its azimuth steps back.
  bool old_packet = false;
};

// A packet sent again, or held, for longer than the reorder window but less than half a turn: its
// own time (`back_ns` behind the previous packet's) says it is old. A restart's time goes back by
// seconds or more, a looping replay's by its capture (a turn or more; a capture of one turn loops
// back by just under one: hence half). Not placed (too late for its hole), dropped as out of order:
// taken for a jump back, it ended the scan in progress and counted its packets after it missing (a
// Pandar40P's packet sent again 36 packets later: "20 packets missing", rig chaos seed 25).
[[nodiscard]] constexpr bool old_packet(Nanos back_ns, Nanos packet_period_ns, Nanos turn_ns) noexcept {
  return packet_period_ns > 0 && turn_ns > 0 && back_ns > static_cast<Nanos>(kReorderPackets) * packet_period_ns &&
         2 * back_ns < turn_ns;
}
struct GapResult {
  bool backwards = false;    // duplicate or late (reordered) packet: not decoded, counted
  bool resync = false;       // a jump back farther than reordering explains (sensor restart, a
                             // replayed capture looping): continuity starts over, nothing missing
  std::uint32_t missing = 0; // packets lost in between (inside the FOV)
  int arc = 0;               // forward azimuth arc from prev_az to first_az
  // The azimuth is farther ahead than the sensor time allows (a frozen or corrupted azimuth that
  // happens to look ahead): the packet is corrupt, not the end of a turn (issue 26 item 2, 7).
  bool implausible = false;
  std::uint32_t turns = 0;   // whole turns the sensor time says passed beyond the azimuth's step
};


inline GapResult azimuth_gap(const AzimuthFov& fov, const GapInput& in) noexcept {
  GapResult r;
  r.arc = turn_step(in.prev_az, in.first_az);
  if (in.old_packet) {
    r.backwards = true;
    return r;
  }
  // The sensor's clock went back farther than reordering explains: whatever the azimuth says.
  if (in.packet_period_ns > 0 && in.dt_ns < -static_cast<Nanos>(kReorderPackets) * in.packet_period_ns) {
    r.resync = true;
    return r;
  }
  const int outside = arc_outside(fov, in.prev_az, r.arc);
  const int visible = r.arc - outside;
  const double pkt_arc = in.group_step * in.groups_per_packet;
  double k_az = 0.0;
  if (in.group_step > 0.5) k_az = (visible / in.group_step - in.groups_since_prev) / in.groups_per_packet;
  const bool time_known = in.dt_ns > 0 && in.packet_period_ns > 0;
  double k_t = -1.0;
  if (time_known) {
    k_t = static_cast<double>(in.dt_ns) / static_cast<double>(in.packet_period_ns) - 1.0;
    if (pkt_arc > 0.5) k_t -= outside / pkt_arc;  // the sensor sent nothing there
  }
  // More than half of the visible arc ahead: a step back (duplicate, reordering), unless the
  // sensor's clock says that much time passed.
  if (visible * 2 > fov.length() && !(time_known && k_t >= 0.5)) {
    const int back = kTurn - r.arc;
    const double window = pkt_arc > 0.5 ? kReorderPackets * pkt_arc : 1000.0;
    if (back <= window) {
      r.backwards = true;
    } else {
      r.resync = true;
    }
    return r;
  }
  double k = std::max(0.0, k_az);
  // The azimuth cannot tell whole turns apart; the sensor time can.
  if (time_known && pkt_arc > 0.5) {
    const double per_turn = fov.length() / pkt_arc;
    if (k > k_t + std::max(2.0, per_turn / 8)) {
      r.implausible = true;
      return r;
    }
    if (k_t > k + per_turn / 2) {
      r.turns = static_cast<std::uint32_t>(std::lround(std::min((k_t - k) / per_turn, 1e6)));
      k = k_t;
    }
  }
  // Over a gap of most of a turn the fitted step's error adds up to a packet (a VLP-32C's 150
  // packets lost across the cut, counted 151 by the azimuth:
  // LossAtCut.ABurstLongerThanATurnIsCountedScanByScan): within a packet of it, the sensor's time
  // counts them. Shorter gaps keep the azimuth's count (a Hesai's packet times jitter by a fraction
  // of a packet: over the gaps after a frozen encoder they counted 3 packets too many).
  if (time_known && r.turns == 0 && pkt_arc > 0.5 && k >= fov.length() / pkt_arc / 2 && std::abs(k_t - k) < 1.0)
    k = std::max(0.0, k_t);
  r.missing = static_cast<std::uint32_t>(std::lround(std::min(k, 1e6)));
  return r;
}

// Packets on the visible part of the arc from `from` to `to` (0.01°), at `group_step` per group.
inline std::uint32_t packets_on_arc(const AzimuthFov& fov, int from, int to, double group_step,
                                    int groups_per_packet) noexcept {
  if (group_step <= 0.5) return 0;
  const int arc = turn_step(from, to);
  const int visible = arc - arc_outside(fov, from, arc);
  return static_cast<std::uint32_t>(std::max(0L, std::lround(visible / (group_step * groups_per_packet) - 0.5)));
}

// A sector the sensor stopped sending (its FOV setting changed at run time, issue 26 item 4): the
// same gap two turns in a row is that, not loss, until a packet comes from inside it again. The
// first turn of a new blind sector cannot be told from a loss burst: it is counted missing.
// Positions are the vendor's (0.01° with wrap = kTurn, or packet slots with wrap = 0).
// Learned arcs (up to kArcs) are kept apart from the candidate: another gap in the same turn (a
// loss burst elsewhere) is a new candidate and leaves a learned arc learned. Before, one slot held
// both, and a loss burst beside a learned blind sector made the next turn count the sector missing
// again (rig chaos, OS-LEGACY: 16 phantom packets).
// A gap's packets: the first one missing begins at `first`, one every `pitch`, `n` of them.
struct GapPackets {
  double first = 0, pitch = 0;
  std::uint32_t n = 0;
};

struct BlindArc {
  // Where the sector's ends lie, narrowed turn by turn (positions as offsets from `anchor`): the
  // first packet not sent begins in (s_lo, s_hi], the first sent after it in (e_lo, e_hi]. One
  // turn tells each to a packet's pitch; the packet grid shifts from turn to turn (a VLP-32C sends
  // ~151.5 packets a turn), so the turns together tell it finer. What a gap holding the arc and a
  // loss burst beside it lacks is then counted exactly (blind_packets).
  struct Arc {
    long from = 0, to = 0, margin = 0;
    bool on = false;
    bool bounded = false;
    long anchor = 0;
    double s_lo = 0, s_hi = 0, e_lo = 0, e_hi = 0;
  };

  static constexpr int kArcs = 2;  // seen() lists them
  Arc arcs[kArcs];  // learned
  Arc cand;         // a gap seen once
  int next = 0;     // the learned slot a new arc takes when both are on
  bool candidate = false, learned = false;  // any candidate / any learned arc (kept for callers)

  static long dist(long x, long y, long wrap) noexcept {
    long d = x > y ? x - y : y - x;
    return wrap > 0 && d > wrap / 2 ? wrap - d : d;
  }
  // A gap from `a` to `b` (tol: how far its ends may move from turn to turn; inner: how far inside
  // its ends a packet must lie to be one the gap lacked: a packet's width where the packet grid
  // shifts from turn to turn, 0 for packet slots): true when it is a blind arc. `inner` must
  // leave room inside a gap of two packets, or a loss burst there would never be unlearned and the
  // next burst at the same place (lidar.loss_burst at_cut) would pass for a blind sector.
  // `gap`: the gap's missing packets, to narrow where the sector's ends lie (pitch 0: not known).
  bool is_blind(long a, long b, long tol, long wrap, long inner, const GapPackets& gap = {}) noexcept {
    for (Arc& arc : arcs) {
      if (arc.on && dist(a, arc.from, wrap) <= tol && dist(b, arc.to, wrap) <= tol) {
        arc.from = a;  // its ends move by up to a packet each turn: follow them
        arc.to = b;
        arc.margin = inner;
        narrow(arc, gap, wrap);
        return true;
      }
    }
    if (cand.on && dist(a, cand.from, wrap) <= tol && dist(b, cand.to, wrap) <= tol) {
      Arc* slot = nullptr;
      for (Arc& arc : arcs)
        if (!arc.on && slot == nullptr) slot = &arc;
      if (slot == nullptr) {
        slot = &arcs[next];
        next = (next + 1) % kArcs;
      }
      *slot = cand;  // with what its first turn told of its ends
      slot->from = a;
      slot->to = b;
      slot->margin = inner;
      narrow(*slot, gap, wrap);
      cand.on = false;
      refresh();
      return true;
    }
    cand = Arc{a, b, inner, true};
    narrow(cand, gap, wrap);
    refresh();
    return false;
  }
  // Of a gap's packets (`gap`, holding the learned `arc`: learned_within), those the sector did not
  // send: the ones beginning between its ends as narrowed (the middle of each end's range). Without
  // bounds, the arc's own length in packets.
  [[nodiscard]] static std::uint32_t blind_packets(const Arc& arc, const GapPackets& gap, long wrap) noexcept {
    if (!(gap.pitch > 0) || gap.n == 0) return 0;
    double s = 0, e = 0;
    if (arc.bounded) {
      s = (arc.s_lo + arc.s_hi) / 2;
      e = (arc.e_lo + arc.e_hi) / 2;
    } else {
      s = offset(arc.from, static_cast<double>(arc.from) + gap.pitch / 2, wrap);
      e = s + static_cast<double>(span_of(arc, wrap)) - gap.pitch;
    }
    const double m1 = offset(arc.bounded ? arc.anchor : arc.from, gap.first, wrap);
    const long j0 = std::max(0L, static_cast<long>(std::ceil((s - m1) / gap.pitch)));
    const long j1 = std::min(static_cast<long>(gap.n) - 1, static_cast<long>(std::ceil((e - m1) / gap.pitch)) - 1);
    return j1 >= j0 ? static_cast<std::uint32_t>(j1 - j0 + 1) : 0U;
  }
  // A gap from `a` to `b` that holds a learned arc and more: a loss burst right beside the blind
  // sector, on either side or both (is_blind() said no). The arc, else nullptr: its packets were not
  // sent, the rest of the gap's were lost (rig chaos seed 3, OS-LEGACY: 10 packets lost right after
  // a learned 16-packet arc were counted 26 missing).
  [[nodiscard]] const Arc* learned_within(long a, long b, long tol, long wrap) const noexcept {
    const auto fwd = [wrap](long x, long y) { return forward(y - x, wrap); };
    const long span = fwd(a, b);
    for (const Arc& arc : arcs) {
      if (!arc.on) continue;
      const long from = dist(a, arc.from, wrap) <= tol ? 0 : fwd(a, arc.from);
      const long to = dist(b, arc.to, wrap) <= tol ? span : fwd(a, arc.to);
      if (from >= 0 && from < to && to <= span) return &arc;
    }
    return nullptr;
  }
  // A gap from a learned arc's start `a` to `b` inside it, short of its end: the sector ended while
  // the rotor was in it (the sensor sends again from `b` on), and the packets before `b` were not
  // sent. A loss burst that begins where the sector began, with the sector already gone, is the one
  // case it would hide. (rig chaos seed 9 with drawn parameters: a VLP-32C's 331-degree sector
  // ending mid-turn, 23 packets counted missing that were never sent.)
  [[nodiscard]] bool ended_inside(long a, long b, long tol, long wrap) const noexcept {
    for (const Arc& arc : arcs) {
      if (!arc.on || dist(a, arc.from, wrap) > tol) continue;
      const long at = forward(b - arc.from, wrap);
      if (at > arc.margin && at < forward(arc.to - arc.from, wrap) - tol) return true;
    }
    return false;
  }
  // A packet at `at`: from inside a blind arc (or the candidate), the sector sends again.
  void seen(long at, long wrap) noexcept {
    if (!candidate && !learned) return;
    const auto inside = [&](const Arc& arc) {
      return forward(at - arc.from, wrap) > arc.margin &&
             forward(at - arc.from, wrap) < forward(arc.to - arc.from, wrap) - arc.margin;
    };
    bool changed = false;
    for (Arc* arc : {&arcs[0], &arcs[1], &cand}) {
      if (arc->on && inside(*arc)) {
        arc->on = false;
        changed = true;
      }
    }
    if (changed) refresh();
  }

 private:
  // `d` taken forward onto [0, wrap) (wrap 0: as it is). Called per packet (seen()): positions lie
  // within a turn, so one add or subtract does it; the modulo only for what lies farther (a
  // division per packet and arc cost the OS-LEGACY capture 11 % once its arcs wrapped, stop 52).
  static long forward(long d, long wrap) noexcept {
    if (wrap <= 0) return d;
    if (d < 0) d += wrap;
    if (d >= wrap) d -= wrap;
    return d >= 0 && d < wrap ? d : ((d % wrap) + wrap) % wrap;
  }
  // `x` as a signed offset from `anchor` (within half a turn).
  static double offset(long anchor, double x, long wrap) noexcept {
    double d = x - static_cast<double>(anchor);
    if (wrap > 0) {
      d = std::fmod(d, static_cast<double>(wrap));
      if (d < 0) d += static_cast<double>(wrap);
      if (d > static_cast<double>(wrap) / 2) d -= static_cast<double>(wrap);
    }
    return d;
  }
  static long span_of(const Arc& arc, long wrap) noexcept {
    return forward(arc.to - arc.from, wrap);
  }
  // This turn's gap tells where the sector's ends lie: kept with what the turns before told, or
  // taken alone where they disagree (the sector moved).
  static void narrow(Arc& arc, const GapPackets& gap, long wrap) noexcept {
    if (!(gap.pitch > 0) || gap.n == 0) return;
    if (!arc.bounded) arc.anchor = arc.from;
    const double m1 = offset(arc.anchor, gap.first, wrap);
    const double s_lo = m1 - gap.pitch, s_hi = m1;
    const double e_lo = m1 + (gap.n - 1) * gap.pitch, e_hi = m1 + gap.n * gap.pitch;
    if (arc.bounded && std::max(arc.s_lo, s_lo) < std::min(arc.s_hi, s_hi) && std::max(arc.e_lo, e_lo) < std::min(arc.e_hi, e_hi)) {
      arc.s_lo = std::max(arc.s_lo, s_lo);
      arc.s_hi = std::min(arc.s_hi, s_hi);
      arc.e_lo = std::max(arc.e_lo, e_lo);
      arc.e_hi = std::min(arc.e_hi, e_hi);
      return;
    }
    arc.s_lo = s_lo;
    arc.s_hi = s_hi;
    arc.e_lo = e_lo;
    arc.e_hi = e_hi;
    arc.bounded = true;
  }
  void refresh() noexcept {
    candidate = cand.on;
    learned = false;
    for (const Arc& arc : arcs) learned = learned || arc.on;
  }
};

// Packets lost on an arc that crosses `cut`, split between the scan that ends and the next one
// exactly as the truth record's units do (mock/unit_tracker.hpp): each lost group is placed where
// the sensor would have sent it, counted back from the first group received after the gap at
// `group_step` (its azimuth rounded as the sensor's), and the group that crosses the cut (the
// first at or past it) decides. A packet with a group past the crossing one, or the crossing one
// itself, is the next scan's; a packet with a group before the crossing one is the ending scan's,
// and so is one whose group crosses when `crossing` says that group is in both (Hesai: it
// touches both scans; Velodyne: it starts the next). A packet with firings on both sides is in
// both. Before, the packets past the cut were rounded to the nearest whole packet (Hesai) or
// judged with half a group's tolerance (Velodyne): one lost packet at the cut was charged to the
// wrong scan when the cut fell in its far half (hidden in one scan, phantom in the other).
struct CutSplit {
  std::uint32_t before = 0, after = 0;
};
enum class CrossingGroup : std::uint8_t { kNextOnly, kBoth };

// Back index (0: the first group after the gap, 1: the one before it, ...) of the earliest group
// at or past `target` on the arc up to `first_az`; `target` lies on that arc.
inline long crossing_back_index(const AzimuthFov& fov, int target, int first_az, double group_step) noexcept {
  const int arc = turn_step(target, first_az);
  const int visible = arc - arc_outside(fov, target, arc);
  // Group b lies at first_az - round(b * step): at or past the target while round(b * step) <= visible.
  return static_cast<long>(std::ceil((visible + 0.5) / group_step)) - 1;
}
// Of `missing` lost packets (the last one's last group at back index `groups_before_first`), those
// whose every group lies at back indices <= b, and those with any group there.
inline std::uint32_t lost_wholly_within(long b, int groups_before_first, int groups_per_packet, std::uint32_t missing) noexcept {
  const long n = b - groups_before_first + 1;
  return n <= 0 ? 0U : static_cast<std::uint32_t>(std::min<long>(n / groups_per_packet, missing));
}
inline std::uint32_t lost_touching_within(long b, int groups_before_first, int groups_per_packet, std::uint32_t missing) noexcept {
  const long n = b - groups_before_first;
  return n < 0 ? 0U : static_cast<std::uint32_t>(std::min<long>(n / groups_per_packet + 1, missing));
}

// The azimuth per group across a gap of `groups` group steps from `prev_az` to `first_az`: one
// packet's fitted step is off by up to ~1/groups of a 0.01° from its rounded azimuths, which over a
// burst of lost packets adds up to a fraction of a group (a VLP-32C, 19.9 hundredths of a degree per
// group: 5 lost packets placed ~0.05° off, one of them charged to the wrong scan at the cut). `fit_step` when the gap
// disagrees with it by half a group or more, or by a 256th of its groups where that is more (the
// fitted step's error grows with the gap: 7 groups over a turn of a VLP-32C); packets rejected
// inside it or a blind arc make it disagree by far more.
inline double gap_group_step(const AzimuthFov& fov, int prev_az, int first_az, long groups, double fit_step) noexcept {
  if (groups <= 0 || fit_step <= 0.5) return fit_step;
  const int arc = turn_step(prev_az, first_az);
  const double visible = arc - arc_outside(fov, prev_az, arc);
  const double tolerance = fit_step * std::max(0.5, static_cast<double>(groups) / 256);
  return std::abs(visible - fit_step * static_cast<double>(groups)) < tolerance ? visible / static_cast<double>(groups) : fit_step;
}

// The same across a gap of `turns` whole turns besides its arc: the step its groups (all of them,
// counted from the sensor's time) span, where it agrees with the fitted one within 1/64 (over a turn
// the fitted step's error adds up to a group: a VLP-32C at 1200 rpm dual, a packet charged wrong).
inline double turns_group_step(const AzimuthFov& fov, int prev_az, int first_az, std::uint32_t turns, long groups,
                               double fit_step) noexcept {
  if (groups <= 0 || fit_step <= 0.5) return fit_step;
  const int arc = turn_step(prev_az, first_az);
  const double visible = arc - arc_outside(fov, prev_az, arc) + static_cast<double>(turns) * fov.length();
  const double step = visible / static_cast<double>(groups);
  return std::abs(step - fit_step) < fit_step / 64 ? step : fit_step;
}

inline CutSplit split_missing_at_cut(const AzimuthFov& fov, int cut, int first_az, double group_step,
                                     int groups_before_first, int groups_per_packet, std::uint32_t missing,
                                     CrossingGroup crossing) noexcept {
  if (group_step <= 0.5) return {missing, 0};
  const long b = crossing_back_index(fov, cut, first_az, group_step);
  // Past the cut only: every group at or past the crossing one (Velodyne), or past it (Hesai).
  const long past_only = crossing == CrossingGroup::kBoth ? b - 1 : b;
  return {missing - lost_wholly_within(past_only, groups_before_first, groups_per_packet, missing),
          lost_touching_within(b, groups_before_first, groups_per_packet, missing)};
}

// Across a gap of whole turns (its turns lost scans between): the packets the ending scan lacks,
// those lost after the last kept group at `prev_az` that have a group before `end` (where the scan
// ends: the cut, Hesai's window end), counted forward at `group_step` (group j after it at
// prev_az + round(j * step), `trailing_bad` of them the last kept packet's own); and those the
// next scan lacks, the lost packets with a group at or past `start` (where it begins: the cut,
// Hesai's window start) before the first kept group at `first_az`, counted back from it
// (`groups_before_first`: its packet's groups up to it). As the truth's units: a packet across
// the boundary is in both. Before, each was its arc in whole packets, rounded down: a VLP-32C's
// 340-packet burst (2.2 turns) left one packet out of the ending scan, whatever the model
// (LossAtCut.ABurstLongerThanATurnIsCountedScanByScan; rig chaos seed 9 with drawn parameters).
// `crossing`: whether the group that crosses `end` (the first at or past it) is the ending scan's
// too (Hesai: it touches both scans). Left out, a lost packet that began with that group was
// missing from the ending scan's count (rig chaos, lidar.loss_burst on a Pandar40P: "72 packets of
// scan 882 lost, 71 counted"; LossAtCut...AtEveryPhaseOfThePacketGrid).
inline std::uint32_t lost_before(const AzimuthFov& fov, int prev_az, int end, double group_step, int groups_per_packet,
                                 int trailing_bad, CrossingGroup crossing = CrossingGroup::kNextOnly) noexcept {
  if (group_step <= 0.5) return 0;
  const int arc = turn_step(prev_az, end);
  const int visible = arc - arc_outside(fov, prev_az, arc);
  // Groups j >= 1 with round(j * step) < visible (and the crossing one, the next, where it is in
  // both): lost packet k holds groups trailing_bad + (k-1)g + 1 ..
  const long groups = static_cast<long>(std::ceil((visible - 0.5) / group_step)) - (crossing == CrossingGroup::kBoth ? 0 : 1);
  const long first_lost = trailing_bad + 1;
  return groups < first_lost ? 0U : static_cast<std::uint32_t>((groups - first_lost) / groups_per_packet + 1);
}
inline std::uint32_t lost_after(const AzimuthFov& fov, int start, int first_az, double group_step, int groups_per_packet,
                                int groups_before_first) noexcept {
  if (group_step <= 0.5) return 0;
  return lost_touching_within(crossing_back_index(fov, start, first_az, group_step), groups_before_first, groups_per_packet,
                              std::numeric_limits<std::uint32_t>::max());
}

// The scans the packets rejected whole around a silence made, for an azimuth model (stream_gap.hpp;
// Velodyne and Hesai alike, `start` where their scans begin: the cut, the window's reset):
// - before it, `rejected` packets of `packet_arc` after the last kept one at `prev_az` turned on to
//   the start and past it: packet k reaches it when its last group does;
// - after it, `rejected` packets before the kept one at `first_az` (the new stream's): the starts
//   between the first of them and that packet, whose own turn's packets are its scan's.
inline std::uint64_t scans_begun_before_silence(const AzimuthFov& fov, int prev_az, int start, double packet_arc,
                                                std::uint32_t rejected) noexcept {
  int arc = turn_step(prev_az, start);
  if (arc == 0) arc = kTurn;  // the last kept group began this scan at the start
  const int visible = arc - arc_outside(fov, prev_az, arc);
  return scans_begun_while_rejected(rejected, std::ceil(visible / packet_arc), fov.length() / packet_arc);
}
inline std::uint64_t scans_ended_after_silence(const AzimuthFov& fov, int start, int first_az, double packet_arc,
                                               std::uint32_t rejected) noexcept {
  const int arc = turn_step(start, first_az);
  const int visible = arc - arc_outside(fov, start, arc);
  return scans_ended_while_rejected(rejected, std::floor(visible / packet_arc), fov.length() / packet_arc);
}

}  // namespace sensor_rig::lidar::detail
