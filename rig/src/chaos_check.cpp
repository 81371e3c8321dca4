#include "chaos_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <set>

#include "chaos_count.hpp"
#include "chaos_fused_check.hpp"
#include "chaos_fault_end.hpp"
#include "chaos_unit_match.hpp"
#include "chaos_units.hpp"

namespace sensor_rig::rig::chaos {
namespace {

constexpr std::size_t kExamplesPerInvariant = 5;
Nanos seconds_ns(double s) { return static_cast<Nanos>(std::llround(s * 1e9)); }
double ms(Nanos ns) { return static_cast<double>(ns) * 1e-6; }

bool is_camera(const std::string& cls) { return cls == "camera" || cls == "v4l2"; }

double stamp_bound_ms(const std::string& cls, const Bounds& b) {
  if (cls == "lidar") return b.lidar_stamp_ms;
  if (is_camera(cls)) return b.camera_stamp_ms;
  return b.other_stamp_ms;
}

double recovery_bound_s(const std::string& cls, const Bounds& b) {
  if (cls == "lidar") return b.lidar_recovery_s;
  if (is_camera(cls)) return b.camera_recovery_s;
  return b.other_recovery_s;
}

// The event touches this device: aimed at it, at a device it depends on, or at the whole host.
bool touches(const faults::FaultEvent& e, const std::string& device, const std::vector<std::string>& depends_on) {
  // "lo": host.network_delay by netem on the loopback (rig chaos gives it no mock), the whole host's.
  if (e.device.empty() || e.device == "lo") return e.device_class() == faults::DeviceClass::kHost;
  if (e.device == device) return true;
  return std::find(depends_on.begin(), depends_on.end(), e.device) != depends_on.end();
}

class Checker {
 public:
  explicit Checker(const Input& in)
      : in_(in),
        doubled_(doubled_vehicle_time(in.truths)),
        held_(netem_delays(in.truths)),
        slews_(slews_after_steps_back(in.truths)),
        ends_(in) {}

  Result run() {
    for (const auto& name : kInvariants) r_.invariants[name] = true;
    count_faults();
    std::map<std::string, std::vector<const SampleRecord*>> by_topic;
    for (const auto& s : in_.samples) by_topic[s.topic].push_back(&s);
    for (auto& [topic, v] : by_topic)
      std::sort(v.begin(), v.end(), [](const SampleRecord* a, const SampleRecord* b) { return a->acquisition_ns < b->acquisition_ns; });
    for (const auto& log : in_.truths) {
      if (log.header.topic.empty()) continue;
      check_topic(log, by_topic[log.header.topic]);
    }
    if (in_.fused.enabled) check_fused_cloud(by_topic[kFusedCloudTopic]);
    check_watchdog();
    return std::move(r_);
  }

 private:
  void violation(const std::string& invariant, const std::string& topic, const std::string& what) {
    r_.invariants[invariant] = false;
    // RIG_CHAOS_TRACE: every violation, not only the first examples the report keeps.
    if (std::getenv("RIG_CHAOS_TRACE") != nullptr) std::fprintf(stderr, "violation %s %s: %s\n", invariant.c_str(), topic.c_str(), what.c_str());
    const auto n = std::count_if(r_.examples.begin(), r_.examples.end(), [&](const Example& e) { return e.invariant == invariant; });
    if (static_cast<std::size_t>(n) < kExamplesPerInvariant) r_.examples.push_back(Example{invariant, topic, what});
  }

  // The fused cloud has no truth of its own: its sweeps' members are held against the LIDARs'
  // (chaos_fused_check.cpp); its rate while no fault touched a LIDAR or the host, as any topic's.
  void check_fused_cloud(const std::vector<const SampleRecord*>& samples) {
    const JudgeContext ctx{[this](Nanos t) { return doubled(t); }, [this](Nanos t) { return at_s(t); },
                           [this](const std::string& i, const std::string& topic, const std::string& w) { violation(i, topic, w); },
                           [this](const std::string& topic, std::uint64_t seq) -> const UnitMatch* {
                             const auto it = matched_.find({topic, seq});
                             return it == matched_.end() ? nullptr : &it->second;
                           },
                           [this](const faults::FaultEvent& e) { return ends_.end(e); }};
    check_fused(in_, ctx, r_);
    const auto e = in_.expected.find(kFusedCloudTopic);
    if (e != in_.expected.end()) check_isolation(kFusedCloudTopic, r_.topics[kFusedCloudTopic], samples, e->second.rate_hz, e->second.depends_on);
  }

  // dbw/README.md "Safety rules": the bridge disengages when the ECU status is older than
  // ecu_timeout_ms. A host.network_delay that holds the mock ECU's frames holds its status and its
  // feedback alike: after the delay begins nothing arrives for the hold (plus a period), then the
  // frames come at their period, late. So a bridge engaged before must stay engaged when that
  // silence is shorter than the timeout (a late status is still a status), and must disengage
  // (ecu_timeout) when it is longer. The silence is read from the feedback frames' real sends in the
  // ECU's truth (its status frames leave among them, held alike); the bridge's state from its
  // dbw/bridge status (once a second). Judged for delays no other fault of the ECU or the host
  // overlaps, within the window.
  void check_watchdog() {
    if (in_.dbw_ecu_timeout_ns <= 0) return;
    constexpr Nanos kMargin = 5'000'000;  // a silence this near the timeout: the scheduler's to decide
    const auto starts = [](const std::string& m, const char* p) { return m.rfind(p, 0) == 0; };
    for (const auto& log : in_.truths) {
      if (log.header.device_class != "dbw") continue;
      for (const auto& f : log.faults) {
        if (f.kind != "host.network_delay" || !truth::injected(f)) continue;
        if (f.at_ns < in_.window_begin_ns || f.until_ns > in_.window_end_ns) continue;
        const bool overlapped = std::any_of(in_.events.begin(), in_.events.end(), [&](const faults::FaultEvent& e) {
          return e.id != f.id && touches(e, log.header.device, {}) && event_begin(e) < f.until_ns + 2 * kSecond &&
                 event_end(e) > f.at_ns - kSecond;
        });
        if (overlapped) continue;
        std::vector<Nanos> tx;
        for (const auto& p : log.parts)
          if (p.tx_ns != 0 && p.tx_ns >= f.at_ns - kSecond / 10 && p.tx_ns < f.until_ns + kSecond) tx.push_back(p.tx_ns);
        if (tx.size() < 2) continue;
        std::sort(tx.begin(), tx.end());
        Nanos gap = 0;
        for (std::size_t i = 1; i < tx.size(); ++i) gap = std::max(gap, tx[i] - tx[i - 1]);
        const std::string* before = nullptr;
        for (const auto& [t, m] : in_.dbw_bridge)
          if (t < f.at_ns) before = &m;
        if (before == nullptr || !starts(*before, "engaged")) continue;  // not engaged: nothing to trip
        // Its reports from the delay's start to 1.5 s after its end (a trip is reported within a second).
        bool reported = false;
        std::string off;
        for (const auto& [t, m] : in_.dbw_bridge)
          if (t >= f.at_ns && t < f.until_ns + kSecond * 3 / 2) {
            reported = true;
            if (off.empty() && !starts(m, "engaged")) off = "'" + m + "' at " + at_s(t) + " s";
          }
        if (!reported) continue;
        const std::string what = "host.network_delay (fault " + std::to_string(f.id) + ", " + f.detail.substr(0, f.detail.find(',')) +
                                 ") held the ECU's frames: longest silence " + fmt_s(ms(gap)) + " ms, ecu_timeout_ms " +
                                 fmt_s(ms(in_.dbw_ecu_timeout_ns));
        if (gap + kMargin < in_.dbw_ecu_timeout_ns && !off.empty())
          violation("watchdog", log.header.topic, what + ": the bridge disengaged (" + off + ") though no ECU status was older than the timeout");
        if (gap > in_.dbw_ecu_timeout_ns + kMargin && off.find("ecu_timeout") == std::string::npos)
          violation("watchdog", log.header.topic, what + ": the bridge " + (off.empty() ? std::string("stayed engaged") : "said " + off) +
                                                      ", not disengaged for ecu_timeout");
      }
    }
  }

  Nanos event_begin(const faults::FaultEvent& e) const { return in_.epoch_vehicle_ns + seconds_ns(e.at_s); }
  // A host.network_delay held the traffic at vehicle time t, or released its last held part then
  // (its end plus the hold and a second's margin).
  bool during_network_delay(Nanos t) const {
    return std::any_of(in_.events.begin(), in_.events.end(), [&](const faults::FaultEvent& e) {
      return e.kind == "host.network_delay" && t >= event_begin(e) &&
             t < event_begin(e) + seconds_ns(e.duration_s + e.number("ms", 50.0) * 1e-3 + e.number("jitter_ms", 0.0) * 1e-3 + 1.0);
    });
  }
  Nanos event_end(const faults::FaultEvent& e) const { return in_.epoch_vehicle_ns + seconds_ns(e.at_s + fault_span_s(e)); }

  // Every planned fault whose device writes truth must appear in that record: a campaign that did not
  // inject what it planned proves nothing.
  void count_faults() {
    std::map<std::string, std::set<std::uint64_t>> recorded;  // device -> fault ids
    std::set<std::pair<std::string, std::uint64_t>> host_counted;  // a host fault once, however many mocks record it too
    for (const auto& log : in_.truths)
      for (const auto& f : log.faults) {
        recorded[log.header.device].insert(f.id);
        // In the record with why it was not (truth::kNotInjected): accounted for, not counted injected.
        if (!truth::injected(f)) continue;
        const auto* kind = faults::find_kind(f.kind);
        if (kind == nullptr || kind->device_class != faults::DeviceClass::kHost || host_counted.insert({f.kind, f.id}).second)
          ++r_.faults[f.kind];
      }
    // A device's mock killed (host.kill_mock) for the whole of a fault could not inject it: not a lie.
    auto while_dead = [&](const faults::FaultEvent& e) {
      return std::any_of(in_.events.begin(), in_.events.end(), [&](const faults::FaultEvent& k) {
        return k.kind == "host.kill_mock" && k.device == e.device && k.at_s <= e.at_s &&
               e.at_s + e.duration_s <= k.at_s + fault_span_s(k) + 0.5;  // + the restarted mock's start
      });
    };
    for (const auto& e : in_.events) {
      if (in_.window_end_ns > 0 && event_begin(e) >= in_.window_end_ns) continue;  // planned after the end
      if (while_dead(e)) continue;
      const std::string owner = e.device.empty() ? std::string("host") : e.device;
      const bool host_kind = e.device_class() == faults::DeviceClass::kHost;
      const auto it = recorded.find(host_kind ? std::string("host") : owner);
      if (it == recorded.end() || !it->second.contains(e.id)) {
        ++r_.faults_not_injected[e.kind];
        violation("faults_injected", owner, e.kind + " (fault " + std::to_string(e.id) + " at " + fmt_s(e.at_s) +
                                                " s) is in the plan and in no truth record");
      }
    }
  }

  static std::string fmt_s(double s) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3f", s);
    return b;
  }
  std::string at_s(Nanos t) const { return fmt_s(static_cast<double>(t - in_.epoch_vehicle_ns) * 1e-9); }

  void check_topic(const truth::Log& log, const std::vector<const SampleRecord*>& samples) {
    const std::string& topic = log.header.topic;
    TopicResult& t = r_.topics[topic];
    t.device = log.header.device;
    t.device_class = log.header.device_class;
    const auto exp_it = in_.expected.find(topic);
    const std::vector<std::string> depends = exp_it != in_.expected.end() ? depends_of(exp_it->second) : std::vector<std::string>{};

    // Units in time order, with their parts' fates.
    std::vector<UnitTruth> units = units_of(log);
    const Nanos tolerance = match_tolerance(units);
    const double bound = stamp_bound_ms(t.device_class, in_.bounds);
    std::vector<double> errors;
    auto in_window = [&](Nanos acq) { return acq >= in_.window_begin_ns && acq < in_.window_end_ns && !doubled(acq); };
    auto near_edge = [&](Nanos acq) {
      return !doubled(acq) && ((acq >= in_.window_begin_ns - in_.count_edge_ns && acq < in_.window_begin_ns + in_.count_edge_ns) ||
                               (acq >= in_.window_end_ns - in_.count_edge_ns && acq < in_.window_end_ns + in_.count_edge_ns));
    };

    // Each published sample to its unit by identity where the record has it, else to the unit nearest
    // its stamp. A camera frame is its unit by frame id (the GVSP block id, the V4L2 sequence: the
    // truth unit's low 16 bits) nearest its arrival: after a host clock step back its stamp is held
    // and slewed up to the step late, before and while the rig flags it, and by the stamp it named a
    // neighbour (issue 27: V4L2 frames "published twice", then 11-24 "neither published nor counted"
    // after each -500 ms step, and its doubled-time samples counted at their slewed stamps).
    // A LIDAR scan is its unit by its first packet's arrival (the unit whose first part was sent
    // last before it, within half a period; truth sends and receptions are one host clock): a stamp
    // off by more than half a period (a mapping that followed a host clock step) would name a
    // neighbour, and the judge would report a scan published twice and another unaccounted instead
    // of the stamp's error. No such unit (no arrival in the record): by the stamp.
    const bool by_frame_id = t.device_class == "camera" || t.device_class == "v4l2";
    std::vector<Nanos> host_steps;  // their sizes: how far a frame's arrival may lie from it across one
    for (const auto& step : slews_) host_steps.push_back(step.step);
    const bool by_arrival = t.device_class == "lidar";
    // A CAN frame is its unit by the send that brackets its kernel receive stamp (unit_by_send).
    const bool by_send = t.device_class == "dbw";
    std::map<const SampleRecord*, Nanos> judged_at;  // the acquisition each sample is counted at
    // Units and samples in vehicle time that happened twice are not matched (above), but the rig's
    // count of losses covers them: those units less those samples are the losses it may have counted
    // there, by number (rig chaos, a frozen counter across a -500 ms step: "the rig counted 100
    // can_frames lost, 1 were not published", 99 of them in the doubled second).
    const auto in_doubled_window = [&](Nanos acq) { return acq >= in_.window_begin_ns && acq < in_.window_end_ns && doubled(acq); };
    std::uint64_t doubled_made = 0, doubled_samples = 0;
    for (const UnitTruth& u : units) doubled_made += u.produced > 0 && in_doubled_window(u.rec.acq_ns) ? 1U : 0U;
    // The unit the previous seq was matched to by arrival: a LIDAR publishes its scans in order.
    const SampleRecord* previous = nullptr;
    std::int64_t previous_unit = std::numeric_limits<std::int64_t>::min();
    for (const SampleRecord* s : samples) {
      const bool in_order = previous != nullptr && s->seq > previous->seq;
      UnitTruth* u = by_arrival    ? unit_by_arrival(units, *s, tolerance, held_, in_order ? previous_unit : std::numeric_limits<std::int64_t>::min(),
                                                     doubled(s->first_rx_ns))
                     : by_frame_id ? unit_by_frame_id(units, *s, host_steps)
                     : by_send     ? unit_by_send(units, s->acquisition_ns)
                                   : nullptr;
      if (u != nullptr && by_arrival) {
        previous = s;
        previous_unit = u->rec.unit;
      }
      // Which side of the doubled time's edges a CAN frame's sample lies on is its unit's: its stamp
      // is ~10 us after its unit's, and the edge (where the step was recorded, not made) moves by
      // more: a frame just inside with its sample just outside was neither published nor counted
      // (whole-rig campaign seed 25, a can_frame at the edge of the doubled second, 2 runs of 9).
      const UnitTruth* near = u != nullptr || t.device_class != "dbw" ? u : unit_nearest(units, s->acquisition_ns, tolerance);
      const Nanos side = near != nullptr ? near->rec.acq_ns : s->acquisition_ns;
      if (in_doubled_window(side)) ++doubled_samples;
      if (!in_window(side)) {
        // Just outside the window: matched only to tell which units there were published, since the
        // rig's count of losses is read at the window's edges give or take count_edge_ns (below).
        if (u == nullptr) u = unit_nearest(units, s->acquisition_ns, tolerance);
        if (u != nullptr && u->sample == nullptr && !in_window(u->rec.acq_ns) && near_edge(u->rec.acq_ns)) u->sample = s;
        // The monitor's check counts it at its unit too: a stamp slewed late after a clock step
        // back lies past the doubled time its scan was made in, and counted there it was a sample
        // of no unit (LIDAR campaign seed 7: "monitor: received 286 ... the device made 284").
        if (u != nullptr) judged_at[s] = u->rec.acq_ns;
        continue;
      }
      // A CAN frame is its unit by its receive stamp; a burst of them (held by host.network_delay,
      // leaving together when it ends) within 1 ms of each other: the nearest one not yet published.
      // Only where a hold can have made such a burst: elsewhere two units within 1 ms are the two
      // timelines of a host clock step back (doubled time), and the free one of them is the other
      // timeline's frame (whole-rig campaign seed 25: a frame of the doubled second neither published
      // nor counted, its sample given to its twin, 2 runs of 7).
      if (u == nullptr)
        u = t.device_class == "dbw" && during_network_delay(s->acquisition_ns)
                ? unit_nearest_free(units, s->acquisition_ns, tolerance, kSecond / 1000)
                : unit_nearest(units, s->acquisition_ns, tolerance);
      judged_at[s] = u != nullptr ? u->rec.acq_ns : s->acquisition_ns;
      if (u == nullptr) {
        ++t.unmatched;
        violation("stamps", topic, "seq " + std::to_string(s->seq) + " stamped at " + at_s(s->acquisition_ns) +
                                       " s matches no " + log.header.unit + " the device made");
        continue;
      }
      matched_[{topic, s->seq}] = UnitMatch{u->rec.unit, u->rec.acq_ns, std::max(u->rec.acq_ns, u->first_intact_acq)};
      if (u->sample != nullptr) {
        ++t.published_twice;
        violation("accounted", topic, log.header.unit + " " + std::to_string(u->rec.unit) + " published twice (seq " +
                                          std::to_string(u->sample->seq) + " and " + std::to_string(s->seq) + ")");
        continue;
      }
      u->sample = s;
    }

    std::uint64_t not_published = 0;
    // RIG_CHAOS_TRACE: every unit not published, to hold against the rig's count second by second
    // (logs/monitor_lines.jsonl) where the counts disagree by number.
    const bool trace = std::getenv("RIG_CHAOS_TRACE") != nullptr;
    for (UnitTruth& u : units) {
      if (!in_window(u.rec.acq_ns) || u.produced == 0) continue;
      ++t.sent;
      if (u.sample == nullptr) {
        ++not_published;
        if (trace) std::fprintf(stderr, "unpublished %s %s %lld at %s s\n", topic.c_str(), log.header.unit.c_str(),
                                static_cast<long long>(u.rec.unit), at_s(u.rec.acq_ns).c_str());
        continue;
      }
      const SampleRecord& s = *u.sample;
      // The stamp: the unit's first firing, or (its first parts lost) anywhere up to the first part that
      // arrived: a rig may extrapolate or stamp what it got.
      // A CAN frame's: anywhere in its send (the kernel stamps it there, however late the sender ran).
      const Nanos lo = u.rec.acq_ns, hi = std::max({lo, u.first_intact_acq, u.own_first_acq, by_send ? u.last_tx : Nanos{0}});
      const Nanos err = s.acquisition_ns < lo ? lo - s.acquisition_ns : s.acquisition_ns > hi ? s.acquisition_ns - hi : 0;
      errors.push_back(ms(err));
      // A camera frame held on the network (host.network_delay) keeps its exposure: its stamp is the
      // camera's (mapped) clock, and a late arrival is no reason for it to move, so a flag does not
      // excuse a stamp that moved then (nor in the settle after it, while a mapping that followed the
      // arrivals comes back). A LIDAR's mapped stamps may follow them, flagged (docs/faults.md).
      const std::uint64_t held_by = is_camera(t.device_class) ? network_hold_of(log, units, u) : 0;
      // In a hold a flag still excuses a stamp late by no more than a host clock step's slew may
      // leave (flagged, by design); the rest would be the hold's (10-minute campaign, seed 2:
      // corner_rear_left 118-158 ms late in a 50 ms hold 2.5 s after a -500 ms step).
      const bool slew_explains = s.acquisition_ns >= lo && ms(err) <= ms(slew_bound(slews_, u.rec.acq_ns)) + bound;
      if (ms(err) > bound && (held_by == 0 || slew_explains) && flagged(topic, s.out_ns())) {
        ++t.stamps_flagged;
      } else if (ms(err) > bound) {
        ++t.stamps_outside;
        violation("stamps", topic, "seq " + std::to_string(s.seq) + ": stamp " + fmt_s(ms(s.acquisition_ns - lo)) +
                                       " ms from the true acquisition of " + log.header.unit + " " + std::to_string(u.rec.unit) +
                                       " (bound " + fmt_s(bound) + " ms)" +
                                       (held_by != 0 ? "; the network held it (host.network_delay, fault " + std::to_string(held_by) +
                                                           "): a late arrival does not move an exposure"
                                                     : std::string{}));
      }
      const std::uint32_t reported = s.missing_packets + s.dropped;
      if (reported < u.lost) {
        t.hidden_missing += u.lost - reported;
        violation("accounted", topic, "seq " + std::to_string(s.seq) + ": " + std::to_string(u.lost) + " packets of " +
                                          log.header.unit + " " + std::to_string(u.rec.unit) + " lost, " +
                                          std::to_string(reported) + " counted");
      }
      if (s.missing_packets > u.lost + u.damaged + u.late + u.new_blind + u.never_made) {
        t.phantom_missing += s.missing_packets - (u.lost + u.damaged + u.late + u.new_blind + u.never_made);
        violation("no_phantom_loss", topic, "seq " + std::to_string(s.seq) + ": " + std::to_string(s.missing_packets) +
                                                " packets counted missing, " + std::to_string(u.lost + u.damaged) +
                                                " lost or damaged" +
                                                (u.late > 0 ? ", " + std::to_string(u.late) + " reordered past its end" : "") +
                                                (u.not_sent > 0 ? ", " + std::to_string(u.not_sent) + " not sent" +
                                                                      (u.new_blind > 0 ? " (a new blind arc)" : " (the previous turn's blind arc)")
                                                                : "") +
                                                (u.never_made > 0 ? ", " + std::to_string(u.never_made) + " never made (its mock killed)" : ""));
      }
      const bool incomplete = s.missing_packets > 0 || s.dropped > 0 || u.lost > 0;
      ++(incomplete ? t.published_incomplete : t.published_complete);
    }
    // The rig's count covers the units made in doubled time too: held against those not published
    // there by number, and against each judged unit by identity (chaos_count.hpp).
    CountFacts facts;
    if (const auto counted = in_.counted_lost.find(topic); counted != in_.counted_lost.end()) facts.rig_counted = counted->second;
    facts.not_published = not_published;
    facts.doubled_made = doubled_made;
    facts.doubled_samples = doubled_samples;
    // A dbw.bad_crc second across the window's end: 11 of its 100 frames were "neither published nor
    // counted" when held against the window itself.
    for (const UnitTruth& u : units) {
      if (u.produced == 0 || u.sample != nullptr || !near_edge(u.rec.acq_ns)) continue;
      ++(in_window(u.rec.acq_ns) ? facts.edge_in : facts.edge_out);
    }
    // A V4L2 frame done and gone with its device (v4l2.disconnect) before the rig dequeued it: no
    // call tells of it (whole-rig campaign seed 25: a frame done 1 ms before the unplug, "neither
    // published nor counted"); the rig may count it lost (from its rate) or not.
    std::set<std::uint64_t> unplugs;
    for (const auto& f : log.faults)
      if (f.kind == "v4l2.disconnect") unplugs.insert(f.id);
    for (const UnitTruth& u : units)
      if (u.produced > 0 && u.sample == nullptr && u.lost > 0 && unplugs.contains(u.lost_fault) && in_window(u.rec.acq_ns) &&
          !near_edge(u.rec.acq_ns))
        ++facts.unseeable;
    // Slots a frozen alive counter hides the ECU's silence in: each looks like a lost frame to the
    // rig (the count's window, like the edges', give or take count_edge_ns).
    if (t.device_class == "dbw") {
      facts.silent_slots = slots_skipped_while_frozen(log, in_.window_begin_ns - in_.count_edge_ns, in_.window_end_ns + in_.count_edge_ns);
      // A counter gap the bridge said it could not size (a silence with room for a whole counter
      // turn: k lost or k + a turn, or an ECU that restarted): the frames lost next to it, up to a
      // turn less one (16 values at most), may be missing from its count. Honest, not hidden: it
      // said so (whole-rig campaign seed 25 with drawn parameters: a dbw.loss p=0.137 around the
      // mock ECU's 482 ms stall, "1 can_frame neither published nor counted lost").
      constexpr std::uint64_t kMostPerUnknownGap = 15;
      facts.unseeable += std::min(not_published, in_.dbw_gaps_unknown * kMostPerUnknownGap);
    }
    // A LIDAR's turns unheard: they cover its units lost whole in silences, within the count's window.
    if (const auto unheard = in_.unheard.find(topic); unheard != in_.unheard.end()) {
      facts.rig_unheard = unheard->second;
      const Unheard truth = unheard_of(log, units, in_.window_begin_ns - in_.count_edge_ns, in_.window_end_ns + in_.count_edge_ns);
      facts.unheard_units = truth.units;
      facts.turns_unmade = truth.turns_unmade;
    }
    const CountVerdict count = reconcile_count(facts);
    if (count.over_unheard)
      violation("no_phantom_loss", topic, "the rig heard nothing in " + std::to_string(facts.rig_unheard) + " turns; " +
                                              std::to_string(facts.unheard_units) + " " + log.header.unit +
                                              "s were lost whole in a silence and " + std::to_string(facts.turns_unmade) +
                                              " turns made nothing");
    // Units and the rig's count are reconciled by number: in doubled time, and wherever the rig
    // counts a loss by the gap it sees, which units the count missed is not known. Said so: "17 of
    // them made while the host clock read a time twice" sent a reader to the doubled second, while the
    // rig had counted those and fallen behind by 17 elsewhere (the ten-minute campaign, seed 3; found
    // from the monitor's count second by second, logs/monitor_lines.jsonl).
    const std::string besides = count.doubled_lost > 0 ? " (" + std::to_string(count.doubled_lost) +
                                                             " not published were made while the host clock read a time twice)"
                                                       : "";
    const std::string silent = facts.silent_slots > 0 ? "; " + std::to_string(facts.silent_slots) +
                                                            " slots the device sent nothing in while its counter stood still allowed"
                                                      : "";
    if (count.over_counted)
      violation("no_phantom_loss", topic, "the rig counted " + std::to_string(facts.rig_counted) + " " + log.header.unit + "s lost, " +
                                              std::to_string(count.most - facts.silent_slots) + " were not published" + besides + silent);
    const std::uint64_t unaccounted_all = count.unaccounted_all;
    t.unaccounted = count.unaccounted;
    t.counted_lost = count.counted_lost;
    t.counted_unheard = count.counted_unheard;
    if (unaccounted_all > 0) {
      std::string first = "none: all in the time the host clock read twice";
      for (const UnitTruth& u : units)
        if (in_window(u.rec.acq_ns) && u.produced > 0 && u.sample == nullptr) {
          first = log.header.unit + " " + std::to_string(u.rec.unit) + " at " + at_s(u.rec.acq_ns) + " s" + faults_of(log, u);
          break;
        }
      violation("accounted", topic, std::to_string(unaccounted_all) + " " + log.header.unit +
                                        "s neither published nor counted lost, by number" + besides + "; first not published: " + first);
    }
    set_stamp_errors(t, errors);
    check_isolation(topic, t, samples, exp_it != in_.expected.end() ? exp_it->second.rate_hz : 0.0, depends, judged_at);
    check_recovery(topic, t, units, depends);
    check_monitor(topic, t, units, samples, judged_at);
  }

  static std::vector<std::string> depends_of(const TopicExpectation& e) { return e.depends_on; }

  // `t`, or the end of the host time read twice that lies at it or begins within `reach` after it
  // (the step is undone when the host faults' thread gets to it, a few ms after the plan's end).
  Nanos past_doubled(Nanos t, Nanos reach) const {
    for (const Interval& i : doubled_)
      if (t < i.end && i.begin < t + reach) return i.end;
    return t;
  }

  bool doubled(Nanos t) const {
    return std::any_of(doubled_.begin(), doubled_.end(), [t](const Interval& i) { return t >= i.begin && t < i.end; });
  }

  bool flagged(const std::string& topic, Nanos t) const {
    const auto it = in_.unsynchronized.find(topic);
    if (it == in_.unsynchronized.end()) return false;
    return std::any_of(it->second.begin(), it->second.end(), [t](const auto& iv) { return t >= iv.first && t < iv.second; });
  }

  // The host.network_delay that held this unit's data in its mock (its truth has the fault line),
  // or whose settle it lies in (a mapping that followed the late arrivals returns after it); 0: none.
  // The hold whose frames (or their settle) unit u is of, where the camera's stream had a mapping
  // to hold them against: one that began less than kMappedBeforeHoldNs before the hold (a camera
  // back from camera.dies 0.2-0.3 s before it, whole-rig campaign seed 25, 2 runs of 3) has none.
  // Its mapper locks after 1 s of frames; before, one-way timing cannot tell a held network from
  // the floor of its arrivals, and its stamps may follow them, flagged, as a LIDAR's may.
  std::uint64_t network_hold_of(const truth::Log& log, const std::vector<UnitTruth>& units, const UnitTruth& u) const {
    const Nanos settle = seconds_ns(in_.bounds.settle_s);
    for (const auto& f : log.faults)
      if (f.kind == "host.network_delay" && truth::injected(f) && u.rec.acq_ns >= f.at_ns && u.rec.acq_ns < f.until_ns + settle)
        return stream_began(units, f.at_ns) <= f.at_ns - kMappedBeforeHoldNs ? f.id : 0;
    return 0;
  }
  // When the camera's stream running at `at` began: its frames sent before `at` without a second's
  // gap (a camera that died or was reopened starts a new stream); `at` when none was running then.
  // Frames the camera never sent are no stream: a GigE fake records the frames of its camera.dies
  // `not_sent`, and counted as frames they made a camera back 0.1 s before a hold (its first sent
  // frame 0.2 s into it) one streaming for minutes (10-minute campaign, seed 1: front_narrow).
  static Nanos stream_began(const std::vector<UnitTruth>& units, Nanos at) {
    Nanos began = 0, prev = 0;
    for (const UnitTruth& v : units) {
      if (v.rec.acq_ns >= at) break;
      if (v.produced == 0) continue;
      if (prev == 0 || v.rec.acq_ns - prev > kSecond) began = v.rec.acq_ns;
      prev = v.rec.acq_ns;
    }
    return began == 0 || at - prev > kSecond ? at : began;
  }
  static constexpr Nanos kMappedBeforeHoldNs = 1'500'000'000;

  std::string faults_of(const truth::Log& log, const UnitTruth& u) const {
    std::set<std::string> kinds;
    for (const auto& f : log.faults)
      if (f.unit == u.rec.unit || (u.rec.acq_ns >= f.at_ns - kSecond / 10 && u.rec.acq_ns <= f.until_ns + kSecond / 10))
        kinds.insert(f.kind);
    std::string out;
    for (const auto& k : kinds) out += (out.empty() ? " (faults: " : ", ") + k;
    return out.empty() ? out : out + ")";
  }

  // Intervals of the window in which a fault (its own, a device it depends on, the host's) touched it.
  // A fault of its own (or of a device it depends on) lasts until the device is back, within its
  // recovery bound: how soon it is back is `recovery`'s to judge, not isolation's, which is about a
  // device no fault touched (issue 27: "healthy cameras at >= 95 % of their rate while another is
  // dead"). With the settle alone, a GigE camera the driver reopened 1.1-2.5 s after its own
  // camera.dies or camera.slow_open ended (its reopen backoff; recovery held, 5 s) broke isolation:
  // camera-only campaigns, seed 8 corner_rear_left 72.6 %, seed 5 front_narrow 86.8 and 90.9 %.
  std::vector<Interval> unhealthy(const std::string& device, const std::vector<std::string>& depends,
                                  const std::vector<const SampleRecord*>& samples, double recovery_s) const {
    std::vector<Interval> out;
    for (const auto& e : in_.events) {
      if (!touches(e, device, depends)) continue;
      if (e.kind == "camera.never_answers") {
        out.push_back({in_.window_begin_ns, in_.window_end_ns});
        continue;
      }
      const Nanos end = ends_.end(e);
      Nanos until = end + seconds_ns(in_.bounds.settle_s);
      if (!e.device.empty() && e.device != "lo") {  // aimed at it (or its trigger LIDAR, a killed mock): not host-wide
        Nanos back = end + seconds_ns(recovery_s);
        for (const SampleRecord* s : samples)
          if (s->acquisition_ns >= end && s->missing_packets == 0 && s->dropped == 0) {
            back = std::min(back, s->acquisition_ns);
            break;
          }
        until = std::max(until, back);
      }
      out.push_back({event_begin(e) - kSecond / 5, until});
    }
    return out;
  }

  // A sample counts at the true acquisition of the unit it was matched to, else at its stamp: a
  // stamp slewed for minutes after a host clock step back of 37 s (flagged, so no `stamps` breach)
  // put every frame of five cameras outside the window it was made in ("27 % of the rate").
  void check_isolation(const std::string& topic, TopicResult& t, const std::vector<const SampleRecord*>& samples,
                       double rate_hz, const std::vector<std::string>& depends,
                       const std::map<const SampleRecord*, Nanos>& judged_at = {}) {
    if (rate_hz <= 0) return;
    const auto bad = unhealthy(t.device, depends, samples, recovery_bound_s(t.device_class, in_.bounds));
    auto healthy_at = [&](Nanos x) {
      return std::none_of(bad.begin(), bad.end(), [&](const Interval& i) { return x >= i.begin && x < i.end; });
    };
    // Healthy time, sampled at 10 ms: exact enough for a 5 % share, and simple.
    constexpr Nanos kStep = 10'000'000;
    Nanos healthy_ns = 0;
    for (Nanos x = in_.window_begin_ns; x < in_.window_end_ns; x += kStep)
      if (healthy_at(x)) healthy_ns += kStep;
    if (healthy_ns < 2 * kSecond) return;  // too little healthy time to judge
    std::uint64_t delivered = 0;
    for (const SampleRecord* s : samples) {
      const auto j = judged_at.find(s);
      const Nanos at = j != judged_at.end() ? j->second : s->acquisition_ns;
      if (at >= in_.window_begin_ns && at < in_.window_end_ns && healthy_at(at)) ++delivered;
    }
    const double expected = static_cast<double>(healthy_ns) * 1e-9 * rate_hz;
    t.healthy_rate_share = expected > 0 ? static_cast<double>(delivered) / expected : 1.0;
    if (t.healthy_rate_share < in_.bounds.isolation_min)
      violation("isolation", topic, "while no fault touched it: " + std::to_string(delivered) + " published of " +
                                        fmt_s(expected) + " expected (" + fmt_s(100 * t.healthy_rate_share) + " %)");
  }

  void check_recovery(const std::string& topic, TopicResult& t, const std::vector<UnitTruth>& units,
                      const std::vector<std::string>& depends) {
    const double bound_s = recovery_bound_s(t.device_class, in_.bounds);
    // A device planned dead for the whole run (camera.never_answers) has nothing to recover to: the
    // faults of a device it depends on (its trigger LIDAR) are not its to recover from either.
    if (std::any_of(in_.events.begin(), in_.events.end(),
                    [&](const faults::FaultEvent& e) { return e.kind == "camera.never_answers" && e.device == t.device; }))
      return;
    for (const auto& e : in_.events) {
      if (!touches(e, t.device, depends) || e.kind == "camera.never_answers") continue;
      // Units in host time read a second time have no sample matched (they are reconciled by
      // number): a fault that ends there is judged from where that time ends (a +2 s step undone
      // left 2 s of them: front and left "not back within 1 s", their scans all complete).
      // A killed mock is judged from when its device was back (chaos_fault_end.hpp).
      const Nanos end = past_doubled(ends_.end(e), seconds_ns(bound_s)), deadline = end + seconds_ns(bound_s);
      if (deadline >= in_.window_end_ns || end < in_.window_begin_ns) continue;
      // Judged only when nothing else touches the device before the deadline.
      const bool overlapped = std::any_of(in_.events.begin(), in_.events.end(), [&](const faults::FaultEvent& o) {
        return &o != &e && touches(o, t.device, depends) && event_begin(o) < deadline && event_end(o) > event_begin(e);
      });
      if (overlapped) continue;
      Nanos back = 0;
      for (const UnitTruth& u : units)
        if (u.rec.acq_ns >= end && u.sample != nullptr && u.sample->missing_packets == 0 && u.sample->dropped == 0) {
          back = u.rec.acq_ns;
          break;
        }
      if (back == 0 || back > deadline) {
        violation("recovery", topic, e.kind + " ended at " + at_s(end) + " s: no complete " +
                                         (units.empty() ? std::string("unit") : std::string("sample")) + " within " +
                                         fmt_s(bound_s) + " s");
        continue;
      }
      t.recovery_max_s = std::max(t.recovery_max_s, static_cast<double>(back - end) * 1e-9);
    }
  }

  // What the monitor reports (its record: each sample received or lost; and the units the rig told it
  // it lost) must be what the device made while the monitor watched, exactly.
  void check_monitor(const std::string& topic, TopicResult& t, const std::vector<UnitTruth>& units,
                     const std::vector<const SampleRecord*>& samples, const std::map<const SampleRecord*, Nanos>& judged_at) {
    if (const auto m = in_.monitor.find(topic); m != in_.monitor.end()) {
      t.monitor_received = m->second.received;
      t.monitor_lost = m->second.lost;
    }
    // The monitor's watch within the judged window: from its first sample to its last.
    Nanos a = in_.window_begin_ns, b = in_.window_end_ns;
    if (!samples.empty()) {
      a = std::max(a, samples.front()->acquisition_ns);
      b = std::min(b, samples.back()->acquisition_ns + 1);
    }
    std::uint64_t made = 0, received = 0, lost = 0;
    for (const UnitTruth& u : units)
      if (u.produced > 0 && u.rec.acq_ns >= a && u.rec.acq_ns < b && !doubled(u.rec.acq_ns)) ++made;
    // A sample at its unit's acquisition where it has one (its stamp may be off: judged by `stamps`).
    for (const SampleRecord* s : samples) {
      const auto j = judged_at.find(s);
      const Nanos at = j != judged_at.end() ? j->second : s->acquisition_ns;
      if (at >= a && at < b && !doubled(at)) ++(s->lost() ? lost : received);
    }
    const std::uint64_t counted = t.counted_lost + t.counted_unheard;
    t.monitor_expected = made;
    if (made == 0 && samples.empty()) return;
    if (samples.empty()) {
      violation("monitor_agrees", topic, "the monitor saw no sample; the device made " + std::to_string(made));
      return;
    }
    if (received + lost + counted != made)
      violation("monitor_agrees", topic, "monitor: received " + std::to_string(received) + " + lost " + std::to_string(lost) +
                                             " + counted lost or unheard by the rig " + std::to_string(counted) + " = " +
                                             std::to_string(received + lost + counted) + "; the device made " +
                                             std::to_string(made) + " while it watched");
  }

  const Input& in_;
  const std::vector<Interval> doubled_;
  const std::vector<HeldInterval> held_;
  const std::vector<SlewSpan> slews_;        // host clock steps back whose slew may still run
  const FaultEnds ends_;                     // when each fault ended for its device (a killed mock: when back)
  Result r_;
  std::map<std::pair<std::string, std::uint64_t>, UnitMatch> matched_;  // (topic, seq) -> its truth unit
};

}  // namespace

bool Result::all_held() const {
  return campaign_errors.empty() && std::all_of(invariants.begin(), invariants.end(), [](const auto& kv) { return kv.second; });
}

void set_stamp_errors(TopicResult& t, std::vector<double>& errors_ms) {
  if (errors_ms.empty()) return;
  std::sort(errors_ms.begin(), errors_ms.end());
  const auto at = [&](double q) {
    return errors_ms[std::min(errors_ms.size() - 1, static_cast<std::size_t>(q * static_cast<double>(errors_ms.size())))];
  };
  t.stamp_error_p50_ms = at(0.5);
  t.stamp_error_p99_ms = at(0.99);
  t.stamp_error_max_ms = errors_ms.back();
}

Result check(const Input& in) { return Checker(in).run(); }

}  // namespace sensor_rig::rig::chaos
