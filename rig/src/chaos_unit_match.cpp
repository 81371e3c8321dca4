#include "chaos_unit_match.hpp"

#include <algorithm>
#include <cstdlib>
#include <iterator>
#include <limits>

namespace sensor_rig::rig::chaos {
namespace {

// A part's send and its arrival are read from the same host clock (CLOCK_REALTIME): the arrival is
// after the send, allowing this for the order of the two reads.
constexpr Nanos kArrivalSlack = 1'000'000;

}  // namespace

// Host time that happened twice (a clock step back) gives two units sent at the same
// host time: of those, the first after `after_unit` (the unit of the sample's previous seq: scans
// are published in order), else the one whose acquisition is nearest the stamp (they are the
// step apart). Nearest the stamp alone failed where the stamps were slewed late after an earlier
// step: both scans sent at one host time went to the later unit ("scan 1099511627821 published
// twice (seq 305 and 310)", the earlier unit unaccounted; whole rig: "monitor_agrees off by +3").
// A unit sent while netem held the loopback arrives its delay later (held). A unit whose first
// parts were damaged is also the one whose first intact part went out last before the arrival
// (LIDAR campaign seed 25: the Ouster's first 40 packets of a scan stuck in azimuth, dropped by the
// rig; its sample's first packet came 64 ms after the scan's first send, past half a period, so the
// stamp named the next scan: "published twice (seq 165 and 166)").
UnitTruth* unit_by_arrival(std::vector<UnitTruth>& units, const SampleRecord& s, Nanos tolerance,
                           const std::vector<HeldInterval>& held, std::int64_t after_unit, bool doubled_arrival) {
  if (s.first_rx_ns == 0) return nullptr;
  const auto since = [&](Nanos tx) {
    Nanos d = 0;
    for (const auto& h : held)
      if (tx >= h.begin && tx < h.end) d = h.delay;
    return s.first_rx_ns - tx - d;
  };
  // A unit is found by its first send, or, its head damaged, by its first intact part's (tail_only).
  const auto tail_only = [&](const UnitTruth& u) {
    const Nanos first = since(u.first_tx);
    return !(first >= -kArrivalSlack && first <= tolerance) && u.first_intact_tx != 0 && u.first_intact_tx != u.first_tx;
  };
  const auto after_send = [&](const UnitTruth& u) { return tail_only(u) ? since(u.first_intact_tx) : since(u.first_tx); };
  // Of the units sent within the tolerance before the arrival, one after `after_unit` first: two
  // scans sent at one host time (a step back) need not be within kArrivalSlack of each other (LIDAR
  // campaign seed 11: the Ouster's scan 181 sent 1.005 ms before scan 176's first send, its sample
  // 10 us after 181's, 995 us before 176's went to 176; scan 181 "neither published nor counted",
  // and the monitor one short).
  // Then one sent before the arrival (the slack is for a tie, not for a send after it): the host
  // stalled 2.9 ms between the truth's send of the Ouster's scan 76 and its packet's arrival, and
  // scan 81, sent at the same host time after a -500 ms step, went out 0.47 ms "after" it: nearest
  // the arrival, seq 76 named scan 81 (ChaosCampaign.AHostClockStep..., 1 run in 5: "scan 81
  // published twice (seq 76 and 81)", scan 76 unaccounted, monitor_agrees off by one).
  const auto is_next = [&](const UnitTruth& u) { return u.rec.unit > after_unit; };
  // A unit found by its tail alone whose intact packets went out within two slacks of the next
  // unit's first send, just before the arrival: its last packet straddled the cut (the truth gives a
  // packet to the unit of its first firing; its firings past the cut begin the next turn, and the
  // sample with them). Taken as sent before the arrival, the tail won: the front LIDAR's first scan
  // after a lidar.stuck_azimuth that ended 1 ms before the cut was judged "100.030 ms from its true
  // acquisition", and the fused sweep with it "mixes rotations" (ten-minute campaign, seed 3).
  const auto straddled = [&](const UnitTruth& u, Nanos after, const UnitTruth& b, Nanos b_after) {
    return tail_only(u) && !tail_only(b) && b_after >= -kArrivalSlack && std::llabs(after - b_after) <= 2 * kArrivalSlack;
  };
  const auto better = [&](const UnitTruth& u, Nanos after, const UnitTruth& b, Nanos b_after) {
    if (is_next(u) != is_next(b)) return is_next(u);
    if (straddled(u, after, b, b_after)) return false;
    if (straddled(b, b_after, u, after)) return true;
    if ((after >= 0) != (b_after >= 0)) return after >= 0;
    return after < b_after;
  };
  UnitTruth* best = nullptr;
  Nanos best_after = 0;
  for (auto& u : units) {
    const Nanos after = after_send(u);
    if (u.first_tx == 0 || after < -kArrivalSlack || after > tolerance) continue;
    if (best == nullptr || better(u, after, *best, best_after)) {
      best = &u;
      best_after = after;
    }
  }
  if (best == nullptr) return nullptr;
  // In host time a step back made happen twice, two next units both sent within the tolerance
  // before the arrival are the step's two timelines: the earlier in order is this sample's, however
  // their sends fall. By the read slack alone, the Ouster's scan 490, sent 1.013 ms after its twin
  // 485 at the same host time, took 485's sample (first packet 1.71 ms after 485's send, 0.70 ms
  // after 490's): "scan 490 published twice (seq 485 and 490)" for five scans of the 10-minute
  // campaign, seed 1. Only there: elsewhere the unit before may be within the tolerance by its last
  // intact packets (a scan whose encoder froze, sent whole but for its end), and it took the next
  // scan's sample, its stamp "a period late" (lidar.stuck_azimuth, 3 of 5).
  const bool in_order = after_unit != std::numeric_limits<std::int64_t>::min() && doubled_arrival;
  for (auto& u : units) {
    const Nanos after = after_send(u);
    if (&u == best || u.first_tx == 0 || after < -kArrivalSlack || after > tolerance) continue;
    if (straddled(u, after, *best, best_after)) continue;
    const bool both_next = in_order && u.rec.unit > after_unit && best->rec.unit > after_unit;
    if (std::llabs(after - best_after) > (both_next ? tolerance : kArrivalSlack)) continue;
    const bool u_next = u.rec.unit > after_unit, best_next = best->rec.unit > after_unit;
    if (u_next != best_next) {
      if (u_next) best = &u;
      continue;
    }
    const bool by_order = u_next && after_unit != std::numeric_limits<std::int64_t>::min();
    const bool nearer_stamp = std::llabs(u.rec.acq_ns - s.acquisition_ns) < std::llabs(best->rec.acq_ns - s.acquisition_ns);
    if (by_order ? u.rec.unit < best->rec.unit : nearer_stamp) best = &u;
  }
  return best;
}

UnitTruth* unit_by_frame_id(std::vector<UnitTruth>& units, const SampleRecord& s, const std::vector<Nanos>& host_steps) {
  if (s.first_rx_ns == 0) return nullptr;
  // The nearest unit of its id by `distance`, within 1 s: first as the clocks read, then (none
  // there) beyond a host step between them, its size taken off. In that order: a unit 37.06 s away
  // beside a -37 s step is nearer by the second than the frame's own 0.3 s away.
  const auto nearest = [&](const auto& distance) -> UnitTruth* {
    UnitTruth* best = nullptr;
    for (auto& u : units) {
      if ((static_cast<std::uint64_t>(u.rec.unit) & 0xffff) != (s.seq & 0xffff)) continue;
      if (best == nullptr || distance(u) < distance(*best)) best = &u;
    }
    return best != nullptr && distance(*best) <= kSecond ? best : nullptr;
  };
  const auto apart = [&](const UnitTruth& u) { return std::llabs(u.rec.acq_ns - s.first_rx_ns); };
  if (UnitTruth* u = nearest(apart)) return u;
  return nearest([&](const UnitTruth& u) {
    Nanos off = std::numeric_limits<Nanos>::max();
    for (const Nanos step : host_steps) off = std::min<Nanos>(off, std::llabs(apart(u) - step));
    return off;
  });
}

UnitTruth* unit_by_send(std::vector<UnitTruth>& units, Nanos t) {
  // Units in acquisition order; a send brackets only times after its acquisition, and a bracket
  // spans more than a few units only where a clock step back interleaved two timelines.
  constexpr std::ptrdiff_t kReach = 8;
  const auto it = std::upper_bound(units.begin(), units.end(), t, [](Nanos v, const UnitTruth& u) { return v < u.rec.acq_ns; });
  UnitTruth* found = nullptr;
  for (auto c = it; c != units.begin() && it - c < kReach;) {
    --c;
    if (c->last_tx == 0 || c->last_tx < t) continue;
    if (found != nullptr) return nullptr;
    found = &*c;
  }
  return found;
}

UnitTruth* unit_nearest(std::vector<UnitTruth>& units, Nanos t, Nanos tolerance) {
  auto it = std::lower_bound(units.begin(), units.end(), t, [](const UnitTruth& u, Nanos v) { return u.rec.acq_ns < v; });
  UnitTruth* best = nullptr;
  Nanos best_d = tolerance + 1;
  for (auto c : {it, it == units.begin() ? it : std::prev(it)}) {
    if (c == units.end()) continue;
    const Nanos d = std::llabs(c->rec.acq_ns - t);
    if (d < best_d) {
      best_d = d;
      best = &*c;
    }
  }
  return best_d <= tolerance ? best : nullptr;
}

UnitTruth* unit_nearest_free(std::vector<UnitTruth>& units, Nanos t, Nanos tolerance, Nanos burst) {
  UnitTruth* nearest = unit_nearest(units, t, tolerance);
  if (nearest == nullptr || nearest->sample == nullptr) return nearest;
  const auto lo = std::lower_bound(units.begin(), units.end(), nearest->rec.acq_ns - burst,
                                   [](const UnitTruth& u, Nanos v) { return u.rec.acq_ns < v; });
  UnitTruth* best = nullptr;
  for (auto it = lo; it != units.end() && it->rec.acq_ns <= nearest->rec.acq_ns + burst; ++it)
    if (it->sample == nullptr && (best == nullptr || std::llabs(it->rec.acq_ns - t) < std::llabs(best->rec.acq_ns - t))) best = &*it;
  return best != nullptr ? best : nearest;
}

}  // namespace sensor_rig::rig::chaos
