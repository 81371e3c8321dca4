#include "chaos_fused_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include "chaos_fused_rotations.hpp"
#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::rig::chaos {
namespace {

using fused::a_lidar_moved;
using fused::Lidar;
using fused::Phases;
using fused::phases_between;
using fused::rotation_boundary;
using fused::tied_boundary;

double ms(Nanos ns) { return static_cast<double>(ns) * 1e-6; }
std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}


// The faults that stop a LIDAR and let it return: after them the fused cloud must be whole again.
bool stops_a_lidar(const faults::FaultEvent& e) {
  return e.kind == "lidar.restart" || e.kind == "host.kill_mock" || e.kind == "host.stall_mock";
}


std::string name_of(const std::string& topic) {
  const std::string prefix = "/sensors/lidar/", suffix = "/points";
  if (topic.rfind(prefix, 0) == 0 && topic.size() > prefix.size() + suffix.size())
    return topic.substr(prefix.size(), topic.size() - prefix.size() - suffix.size());
  return topic;
}

class FusedJudge {
 public:
  FusedJudge(const Input& in, const JudgeContext& ctx, Result& r)
      : in_(in), ctx_(ctx), t_(r.topics[kFusedCloudTopic]), period_(in.fused.period_ns > 0 ? in.fused.period_ns : 100'000'000) {}

  void run() {
    t_.device = "fusion";
    t_.device_class = "fusion";
    load();
    place_boundaries();
    for (const FusedSet& set : in_.fused.sets) judge_sweep(set);
    account_scans();
    unpaired_clouds();
    report();
    set_stamp_errors(t_, errors_);
    check_recovery();
    check_monitor();
  }

 private:
  struct Member {
    const Lidar* lidar;
    const SampleRecord* scan;
    const UnitMatch* truth;  // the LIDAR judge's match; nullptr: none (outside the window, or no scan the mock made)
  };

  // Violations by kind: each kind reported once, its first sweep with the count of sweeps like it,
  // so that the few examples of the verdict show every kind and how often.
  void fail(const std::string& kind, const std::string& what) {
    if (std::getenv("RIG_CHAOS_TRACE") != nullptr) std::fprintf(stderr, "fused %s: %s\n", kind.c_str(), what.c_str());
    const auto it = std::find_if(kinds_.begin(), kinds_.end(), [&](const auto& k) { return k.kind == kind; });
    if (it == kinds_.end()) kinds_.push_back({kind, what, 1});
    else ++it->count;
  }
  void report() const {
    for (const auto& k : kinds_)
      ctx_.violation("fused", kFusedCloudTopic, k.count == 1 ? k.first : k.first + " (1 of " + std::to_string(k.count) + " such)");
  }
  // A member's stamp off its truth by more than the bound (the LIDAR's own `stamps` violation), said.
  // A member's stamp off its truth: before its first firing, or after the first of its parts that
  // arrived (a scan whose head was not sent or lost is stamped there, as the stamps judge allows).
  // Held against its first firing alone, the front's scans under a blind sector from 87 to 30 degrees
  // (stamped 8.3 ms into their turns, rightly) were blamed beside the left and right's flagged ones,
  // and a mix the rig had warned of was broken (ten-minute campaign, seed 9: 3 sweeps).
  std::string own_stamp_error(const Member& m) const {
    if (m.truth == nullptr) return {};
    const Nanos lo = m.truth->acq, hi = std::max(lo, m.truth->first_intact), at = m.scan->acquisition_ns;
    const Nanos own = at < lo ? at - lo : at > hi ? at - hi : 0;
    if (ms(std::llabs(own)) <= in_.bounds.lidar_stamp_ms) return {};
    return m.lidar->name + " seq " + std::to_string(m.scan->seq) + "'s own stamp is " + fmt(ms(own)) + " ms off its truth";
  }
  bool in_window(Nanos x) const { return x >= in_.window_begin_ns && x < in_.window_end_ns && !ctx_.doubled(x); }
  // The boundary in force at time t (pieces of piece_ from the earliest acquisition).
  Nanos boundary_at(Nanos t) const {
    if (boundaries_.empty()) return 0;
    const std::int64_t i = std::clamp<std::int64_t>(floor_div(t - pieces_from_, piece_), 0, static_cast<std::int64_t>(boundaries_.size()) - 1);
    return boundaries_[static_cast<std::size_t>(i)];
  }
  std::int64_t rotation(Nanos acq) const { return floor_div(acq - boundary_at(acq), period_); }
  // Whether the members are one rotation by the tied boundary of the piece `at` lies in.
  bool one_rotation_by_tie(const std::vector<Member>& members, Nanos at) const {
    if (tied_.empty()) return false;
    const std::int64_t i = std::clamp<std::int64_t>(floor_div(at - pieces_from_, piece_), 0, static_cast<std::int64_t>(tied_.size()) - 1);
    const auto& tie = tied_[static_cast<std::size_t>(i)];
    if (!tie) return false;
    std::set<std::int64_t> rotations;
    for (const auto& m : members)
      if (m.truth != nullptr && !short_of_a_turn(m)) rotations.insert(floor_div(m.truth->acq - *tie, period_));
    return rotations.size() == 1;
  }
  // Where rotation n begins (its boundary's piece found from the first piece's numbering, once refined).
  Nanos rotation_start(std::int64_t n) const {
    Nanos start = boundary_at(pieces_from_) + n * period_;
    start = boundary_at(start) + n * period_;
    return start;
  }
  // After a LIDAR moved, the boundary follows the widest gap for this many pieces more: the matcher
  // places it anew at the move or up to its kOwnPhaseScans scans later (a move held as a possible
  // clock step until a witness refutes it), and a LIDAR's first scan after a move may lie off the
  // phase it settles on. Placed by that scan alone, the judge's boundary stayed in the gap it made:
  // the right LIDAR back from 1200 rpm at phase 64 ms, then 59 ms for good beside 0 and 23 ms; the
  // judge kept 43.6 ms (the widest gap of 0/23/64), the matcher placed 79.4 ms (of 0/23/59), and
  // 322 sweeps "mixed rotations" for 32 s (ten-minute campaign, seed 4).
  static constexpr std::int64_t kSettlingPieces = 4;
  // Pieces of a rotation; each LIDAR's phase that of its latest scan up to the piece's end (within
  // three rotations: a LIDAR silent longer has none): the phase of the moment, as the matcher knows
  // it (a LIDAR whose phase changed is taken on its new one from its first scan on it).
  Nanos piece_ = 1;
  void place_boundaries() {
    Nanos lo = std::numeric_limits<Nanos>::max(), hi = std::numeric_limits<Nanos>::min();
    for (const auto& l : lidars_)
      if (!l.acqs.empty()) {
        lo = std::min(lo, l.acqs.front().first);
        hi = std::max(hi, l.acqs.back().first);
      }
    if (lo > hi) return;
    piece_ = period_;
    pieces_from_ = lo;
    std::optional<Nanos> b;
    Phases before;
    std::int64_t since_move = kSettlingPieces + 1;
    for (Nanos t = lo; t <= hi; t += piece_) {
      const Phases ph = phases_between(lidars_, period_, t - 2 * period_, t + period_);
      since_move = a_lidar_moved(before, ph, period_) ? 0 : since_move + 1;
      b = rotation_boundary(ph, since_move <= kSettlingPieces, period_, b);
      boundaries_.push_back(b.value_or(0));
      tied_.push_back(b ? tied_boundary(ph, *b, period_) : std::nullopt);

      // A LIDAR silent in this piece keeps the phase it was last on (the matcher keeps a dead
      // source's): its return on another phase is a move.
      if (before.of.empty()) before = ph;
      for (std::size_t i = 0; i < ph.of.size(); ++i)
        if (ph.of[i] || ph.above[i] != 0) {
          before.of[i] = ph.of[i];
          before.above[i] = ph.above[i];
        }
    }
  }

  void load() {
    for (const auto& topic : in_.fused.lidar_topics) {
      Lidar l;
      l.topic = topic;
      l.name = name_of(topic);
      for (const auto& log : in_.truths) {
        if (log.header.topic != topic) continue;
        std::map<std::int64_t, Nanos> last_firing;  // per unit: its latest packet's (every part made, sent or not)
        for (const auto& p : log.parts) {
          Nanos& last = last_firing[p.unit];
          last = std::max(last, p.acq_ns);
        }
        for (const auto& u : log.units) {
          const auto it = last_firing.find(u.unit);
          const Nanos span = it == last_firing.end() ? 0 : std::max<Nanos>(0, it->second - u.acq_ns);
          l.units.emplace_back(u.acq_ns, span);
        }
      }
      std::sort(l.units.begin(), l.units.end());
      lidar_of_[topic] = lidars_.size();
      lidars_.push_back(std::move(l));
    }
    for (const auto& s : in_.samples) {
      if (s.topic == kFusedCloudTopic) clouds_.emplace(s.seq, &s);
      else if (const auto it = lidar_of_.find(s.topic); it != lidar_of_.end()) lidars_[it->second].by_seq.emplace(s.seq, &s);
    }
    // The phases are those of the scans the rig published (their truth), as the matcher sees only
    // those: a scan made and never sent (a LIDAR restarted within it) moved the judge's boundary
    // and not the matcher's (LIDAR-fault campaign seed 3: the left LIDAR's one scan between two
    // restarts on a phase of its own, "mixes rotations" on the front and right LIDARs for 0.9 s).
    // A LIDAR above the rig's rpm (its scans short of three quarters of a turn, following each other
    // by less) has no phase at the rig's period: its phase moves by half a turn each scan. A scan
    // short of its turn alone (a turn cut by a restart) keeps the phase (the matcher's rule: a
    // LIDAR's long scan still in the window kept its phase in the judge's boundary after it went
    // to 1200 rpm, and 12 sweeps of the same campaign "mixed").
    for (auto& l : lidars_) {
      std::vector<std::pair<Nanos, Nanos>> published;  // (true first firing, span)
      for (const auto& [seq, sample] : l.by_seq) {
        const UnitMatch* m = ctx_.truth_of(l.topic, seq);
        if (m == nullptr) continue;
        const auto it = std::lower_bound(l.units.begin(), l.units.end(), std::make_pair(m->acq, Nanos{0}));
        published.emplace_back(m->acq, it != l.units.end() && it->first == m->acq ? it->second : 0);
      }
      std::sort(published.begin(), published.end());
      published.erase(std::unique(published.begin(), published.end()), published.end());
      bool above = false;
      for (std::size_t i = 0; i < published.size(); ++i) {
        const Nanos span = published[i].second;
        const bool short_of_a_turn = span > 0 && span < period_ - period_ / 4;
        const Nanos advance = i > 0 ? published[i].first - published[i - 1].first : 0;
        if (!short_of_a_turn) above = false;
        else if (advance > 0 && advance < period_ - period_ / 4) above = true;
        l.acqs.emplace_back(published[i].first, above);
      }
    }
  }

  std::string scan_name(const Member& m) const {
    std::string s = m.lidar->name + " seq " + std::to_string(m.scan->seq);
    if (m.truth != nullptr)
      s += " (scan " + std::to_string(m.truth->unit) + ", true acquisition " + ctx_.at_s(m.truth->acq) + " s, rotation " +
           std::to_string(rotation(m.truth->acq) - rotation(in_.window_begin_ns)) + ")";
    return s;
  }

  void judge_sweep(const FusedSet& set) {
    sets_.insert(set.seq);
    for (const auto& m : set.members)
      if (const auto it = lidar_of_.find(m.topic); it != lidar_of_.end()) fused_in_[{it->second, m.seq}].push_back(set.seq);
    // Judged when any member lies in the window, not only its stamp (its earliest member's): a sweep
    // whose earliest scan fired just before the window began holds scans counted in it, and their
    // sweep's verdict is theirs (a fresh clone's suite: the Pandar's first firing 0.9 ms before the
    // window began, the other two after it, counted "incomplete" for want of a verdict).
    if (!in_window(set.stamp) && std::none_of(set.members.begin(), set.members.end(), [&](const FusedMember& m) { return in_window(m.stamp); })) return;
    const std::string sweep = "sweep " + std::to_string(set.seq) + " (stamped at " + ctx_.at_s(set.stamp) + " s)";
    const auto cit = clouds_.find(set.seq);
    const SampleRecord* cloud = cit == clouds_.end() ? nullptr : cit->second;
    if (cloud == nullptr) {
      ++t_.unmatched;
      fail("no_cloud", sweep + ": members published, no fused cloud stamped with its seq");
    } else if (cloud->acquisition_ns != set.stamp) {
      ++t_.unmatched;
      fail("cloud_stamp", sweep + ": the fused cloud is stamped at " + ctx_.at_s(cloud->acquisition_ns) + " s, its members at " +
           ctx_.at_s(set.stamp) + " s");
      cloud = nullptr;
    }
    // The members: scans the LIDARs published (same topic, seq and stamp on /rig/stamps).
    std::vector<Member> members;
    std::set<std::string> topics;
    std::uint32_t packets = 0, dropped = 0, missing = 0;
    bool all_published = true;
    for (const auto& m : set.members) {
      const auto li = lidar_of_.find(m.topic);
      const SampleRecord* s = nullptr;
      if (li != lidar_of_.end())
        if (const auto it = lidars_[li->second].by_seq.find(m.seq); it != lidars_[li->second].by_seq.end() && it->second->acquisition_ns == m.stamp)
          s = it->second;
      if (s == nullptr) {
        ++t_.unmatched;
        all_published = false;
        fail("unpublished", sweep + ": member " + m.topic + " seq " + std::to_string(m.seq) + " stamped at " + ctx_.at_s(m.stamp) +
             " s was never published");
        continue;
      }
      const Lidar& l = lidars_[li->second];
      members.push_back({&l, s, ctx_.truth_of(l.topic, s->seq)});
      if (!topics.insert(m.topic).second) fail("two_scans", sweep + " holds two scans of " + l.name);
      packets += s->packets;
      dropped += s->dropped;
      missing += s->missing_packets;
    }
    // One rotation.
    std::map<std::int64_t, const Member*> rotations;
    const Member* earliest = nullptr;
    for (const auto& m : members) {
      if (m.truth == nullptr) continue;
      if (!short_of_a_turn(m)) rotations.emplace(rotation(m.truth->acq), &m);
      if (earliest == nullptr || m.truth->acq < earliest->truth->acq) earliest = &m;
    }
    if (rotations.size() > 1 && (one_rotation_while_regrouping(members, earliest) || one_rotation_by_tie(members, earliest->truth->acq))) {
      ++t_.mixes_regrouped;
    } else if (rotations.size() > 1) {
      std::string what = sweep + " mixes rotations:";
      for (const auto& [rot, m] : rotations) what += " " + scan_name(*m) + ";";
      const StampBlame blame = blame_stamps(members, cloud, set);
      if (blame.warned) {
        ++t_.mixes_flagged;
      } else {
        fail(blame.why.empty() ? "mixes" : "mixes_by_stamps", blame.why.empty() ? what : what + " " + blame.why);
      }
    }
    // Its stamp: the earliest member's (the fusion's rule), and so that scan's first firing (or up
    // to its first packet that arrived).
    if (!members.empty()) {
      Nanos min_stamp = INT64_MAX;
      for (const auto& m : members) min_stamp = std::min(min_stamp, m.scan->acquisition_ns);
      if (min_stamp != set.stamp)
        fail("stamp_rule", sweep + ": stamped " + fmt(ms(set.stamp - min_stamp)) + " ms from its earliest member's stamp");
    }
    // Its stamp judged when in the window: before it, its earliest member has no truth matched here.
    if (earliest != nullptr && in_window(set.stamp)) {
      const Nanos lo = earliest->truth->acq, hi = earliest->truth->first_intact;
      const Nanos err = set.stamp < lo ? lo - set.stamp : set.stamp > hi ? set.stamp - hi : 0;
      errors_.push_back(ms(err));
      if (ms(err) > in_.bounds.lidar_stamp_ms && flagged(members)) {
        ++t_.stamps_flagged;
      } else if (ms(err) > in_.bounds.lidar_stamp_ms) {
        ++t_.stamps_outside;
        // Stamped with a member's stamp that is off its own truth: the LIDAR's `stamps` violation, inherited.
        std::string inherited;
        for (const auto& m : members)
          if (m.scan->acquisition_ns == set.stamp) inherited = own_stamp_error(m);
        fail(inherited.empty() ? "stamp" : "stamp_inherited",
             sweep + ": stamp " + fmt(ms(set.stamp - lo)) + " ms from the true acquisition of its earliest member " +
                 scan_name(*earliest) + " (bound " + fmt(in_.bounds.lidar_stamp_ms) + " ms)" +
                 (inherited.empty() ? "" : "; inherited: " + inherited));
      }
    }
    if (cloud == nullptr || !all_published) return;
    // Its stamps agree with its members: their packets, their drops, their missing packets plus
    // each absent LIDAR's whole scan.
    const bool says_complete = cloud->missing_packets == 0 && cloud->dropped == 0;
    complete_[set.seq] = says_complete;
    if (cloud->packets != packets || cloud->dropped != dropped || cloud->missing_packets < missing)
      fail("stamps_disagree", sweep + ": its stamps say packets " + std::to_string(cloud->packets) + ", dropped " + std::to_string(cloud->dropped) +
           ", missing " + std::to_string(cloud->missing_packets) + "; its members' scans " + std::to_string(packets) + ", " +
           std::to_string(dropped) + ", " + std::to_string(missing));
    // Absent but covered: a slower LIDAR's scan that began in an earlier rotation spans this one.
    std::size_t covered = 0;
    if (earliest != nullptr)
      for (const auto& l : lidars_)
        if (!topics.contains(l.topic) && (covered_by_slower(l, rotation(earliest->truth->acq)) || covered_in_time(l, *earliest))) ++covered;
    if (says_complete && members.size() + covered == lidars_.size()) whole_.emplace_back(set.stamp, set.seq);
    if (says_complete && members.size() + covered < lidars_.size()) {
      std::string absent;
      for (const auto& l : lidars_) {
        if (topics.contains(l.topic)) continue;
        absent += (absent.empty() ? "" : ", ") + l.name;
        if (const SampleRecord* s = published_in(l, earliest); s != nullptr) absent += " (its scan seq " + std::to_string(s->seq) + " was published)";
      }
      // The absent LIDAR's scan of the earliest member's true rotation went to another sweep because
      // members' stamps (flagged) put this one elsewhere: the rig's own warning, as a mix is (ten-minute
      // campaign, seed 1: a 300 rpm front LIDAR's scan "covered" this rotation by the left and right
      // LIDARs' stamps, slewed 120 ms early after a host clock step back; by their truth it was the next).
      const StampBlame blame = blame_stamps(members, cloud, set);
      if (blame.warned) {
        ++t_.mixes_flagged;
      } else {
        t_.hidden_missing += lidars_.size() - members.size() - covered;
        fail(blame.why.empty() ? "complete_without" : "complete_without_by_stamps",
             sweep + " says complete (missing 0) with " + std::to_string(members.size()) + " of " + std::to_string(lidars_.size()) +
                 " LIDARs; absent: " + absent + (blame.why.empty() ? "" : "; " + blame.why));
      }
    }
    if (members.size() == lidars_.size() && cloud->missing_packets > missing) {
      t_.phantom_missing += cloud->missing_packets - missing;
      fail("phantom", sweep + " holds every LIDAR and counts " + std::to_string(cloud->missing_packets) + " packets missing; its scans miss " +
           std::to_string(missing));
    }
  }

  // Where a LIDAR's phase moved (a restart, an rpm change), the boundary moves with it: the judge
  // places its own by the scans of a piece up to a rotation ahead, the matcher by the scans that have
  // arrived (a turn after they began, two for a slow one), so around the move the two regroup the
  // rotations up to two sweeps apart (one campaign of 68 LIDAR restarts and rpm changes: 8 sweeps,
  // each at a move; the judge also sees the scans a killed mock made and never sent). A sweep one
  // rotation by the boundary in force up to two rotations before or after its earliest member is
  // such a regrouping, not a mix: held, counted (`mixes_regrouped`). Away from a move the boundaries
  // are one, and a sweep mixing rotation N with N+1 is caught as before.
  bool one_rotation_while_regrouping(const std::vector<Member>& members, const Member* earliest) const {
    if (earliest == nullptr) return false;
    const Nanos t = earliest->truth->acq;
    for (const Nanos at : {t - 2 * period_, t - period_, t + period_, t + 2 * period_}) {
      const Nanos b = boundary_at(at);
      std::set<std::int64_t> n;
      for (const auto& m : members)
        if (m.truth != nullptr && !short_of_a_turn(m)) n.insert(floor_div(m.truth->acq - b, period_));
      if (n.size() <= 1) return true;
    }
    return false;
  }
  // A scan short of three quarters of a turn (a LIDAR above the rig's rpm: two or more scans a
  // rotation, each on another phase) has no rotation of its own at the rig's period: the fusion takes
  // one of them, and the sweep is one rotation by its other members. (Its phase is left out of the
  // boundary for the same reason, here as in the matcher's place_boundary.)
  bool short_of_a_turn(const Member& m) const {
    const auto& u = m.lidar->units;
    const auto it = std::lower_bound(u.begin(), u.end(), std::make_pair(m.truth->acq, Nanos{0}));
    return it != u.end() && it->first == m.truth->acq && it->second > 0 && it->second < period_ - period_ / 4;
  }

  // LIDAR `l` began no scan in rotation n, and its scan that began in an earlier rotation spans it
  // (a slower LIDAR: its scan spans k periods, k its last packet's firing after its first in whole
  // periods; the fusion's rule, drivers/README.md "A slower LIDAR"). A LIDAR that stopped is not
  // covered. k was a scan's packets over the LIDAR's median scan's: a LIDAR at 300 rpm throughout
  // (its median a slow scan) had k = 1, and every sweep its scans covered read "says complete
  // with 2 of 3 LIDARs".
  bool covered_by_slower(const Lidar& l, std::int64_t n) const {
    const Nanos start = rotation_start(n);
    auto it = std::lower_bound(l.units.begin(), l.units.end(), std::make_pair(start, Nanos{0}));
    if (it != l.units.end() && it->first < start + period_) return false;  // it began one in n
    if (it == l.units.begin()) return false;
    const auto& [acq, span] = *std::prev(it);
    const auto k = std::max<std::int64_t>(1, (span + period_ / 2) / period_);
    return rotation(acq) < n && n < rotation(acq + k * period_);
  }

  // A slower LIDAR's scan (longer than a turn by its truth) fused into another sweep that began by
  // this sweep's earliest member and spans past it: its points of this time are in the cloud, in the
  // sweep its scan began in, which is what the matcher's `covered` says, whichever rotation a
  // boundary gives the two. The judge's boundary and the matcher's may lie in different gaps where
  // two are nearly equal (ten-minute campaign, seed 2: phases 46 and 43 ms apart as a 300 rpm front
  // LIDAR's turn was cut short on its return to 600 rpm; "complete with 2 of 3").
  bool covered_in_time(const Lidar& l, const Member& earliest) const {
    if (earliest.truth == nullptr) return false;
    const Nanos at = earliest.truth->acq;
    for (const auto& [seq, s] : l.by_seq) {
      const UnitMatch* u = ctx_.truth_of(l.topic, seq);
      if (u == nullptr || u->acq > at || u->acq < at - kMaxSpanPeriods * period_) continue;
      const auto unit = std::lower_bound(l.units.begin(), l.units.end(), std::make_pair(u->acq, Nanos{0}));
      if (unit == l.units.end() || unit->first != u->acq) continue;
      const Nanos span = unit->second;
      if (span <= period_ + period_ / 8 || u->acq + span <= at) continue;
      const bool fused = std::any_of(in_.fused.sets.begin(), in_.fused.sets.end(), [&](const FusedSet& set) {
        return std::any_of(set.members.begin(), set.members.end(), [&](const FusedMember& m) { return m.topic == l.topic && m.seq == seq; });
      });
      if (fused) return true;
    }
    return false;
  }
  static constexpr Nanos kMaxSpanPeriods = 4;  // a scan spans at most this many turns (150 rpm beside 600)

  // After a LIDAR stops and returns (lidar.restart, a killed or stalled mock), the fused cloud is
  // whole again within the LIDAR's recovery bound plus the rotations the matcher may take to place a
  // returned LIDAR's phase (its own phase after 3 scans: 4 periods): a sweep stamped after the
  // fault's end that says complete and holds every LIDAR (or covers a slower one's). Judged when no
  // other fault touches a fused LIDAR (or the host) meanwhile.
  void check_recovery() {
    const Nanos bound = static_cast<Nanos>(in_.bounds.lidar_recovery_s * 1e9) + 4 * period_;
    auto fused_device = [&](const faults::FaultEvent& e) {
      if (e.device.empty()) return e.device_class() == faults::DeviceClass::kHost;
      for (const auto& l : lidars_) {
        const auto x = in_.expected.find(l.topic);
        if (e.device == (x != in_.expected.end() && !x->second.device.empty() ? x->second.device : l.name)) return true;
      }
      return false;
    };
    auto begin_of = [&](const faults::FaultEvent& e) { return in_.epoch_vehicle_ns + static_cast<Nanos>(e.at_s * 1e9); };
    // A killed mock from when its LIDAR was back on the wire (chaos_fault_end.hpp).
    const auto& end_of = ctx_.fault_end;
    std::sort(whole_.begin(), whole_.end());
    for (const auto& e : in_.events) {
      if (!stops_a_lidar(e) || e.device.empty() || !fused_device(e)) continue;
      const Nanos end = end_of(e), deadline = end + bound;
      if (end < in_.window_begin_ns || deadline >= in_.window_end_ns) continue;
      const bool overlapped = std::any_of(in_.events.begin(), in_.events.end(), [&](const faults::FaultEvent& o) {
        return &o != &e && fused_device(o) && begin_of(o) < deadline && end_of(o) > begin_of(e);
      });
      if (overlapped) continue;
      // Back to what was: a cloud not whole in the bound before the fault has no whole to return to
      // (the slew after a +37 s host step, the members' stamps and the cloud flagged, left it partial
      // for minutes: seed 9, 5 faults "not whole again" in the 370 s after two steps). Its partial
      // sweeps are still counted (published_incomplete), and a fault it was whole before is judged.
      const auto before = std::lower_bound(whole_.begin(), whole_.end(), std::make_pair(begin_of(e) - bound, std::uint64_t{0}));
      if (before == whole_.end() || before->first >= begin_of(e)) continue;
      const auto it = std::lower_bound(whole_.begin(), whole_.end(), std::make_pair(end, std::uint64_t{0}));
      if (it == whole_.end() || it->first > deadline) {
        ctx_.violation("recovery", kFusedCloudTopic, e.kind + " on " + e.device + " ended at " + ctx_.at_s(end) +
                                                         " s: no fused sweep whole again (complete, every LIDAR) within " +
                                                         fmt(static_cast<double>(bound) * 1e-9) + " s");
        continue;
      }
      t_.recovery_max_s = std::max(t_.recovery_max_s, static_cast<double>(it->first - end) * 1e-9);
    }
  }

  // The scan of LIDAR `l` published in the rotation of `ref` (nullptr: none, or no reference).
  const SampleRecord* published_in(const Lidar& l, const Member* ref) const {
    if (ref == nullptr || ref->truth == nullptr) return nullptr;
    const auto want = rotation(ref->truth->acq);
    for (const auto& [seq, s] : l.by_seq) {
      const UnitMatch* u = ctx_.truth_of(l.topic, seq);
      if (u != nullptr && rotation(u->acq) == want) return s;
    }
    return nullptr;
  }

  bool topic_flagged(const std::string& topic, Nanos t) const {
    const auto it = in_.unsynchronized.find(topic);
    return it != in_.unsynchronized.end() &&
           std::any_of(it->second.begin(), it->second.end(), [t](const auto& iv) { return t >= iv.first && t < iv.second; });
  }
  // Members whose own stamps are off their truth put the sweep where it is: said (why), and the
  // rig's own warning (warned) when each such member's LIDAR flagged its stamps and the fused cloud
  // flagged its own as they went out, as a flagged stamp is (the matcher has nothing but the stamps
  // to go by).
  struct StampBlame {
    std::string why;
    bool warned = false;
  };
  StampBlame blame_stamps(const std::vector<Member>& members, const SampleRecord* cloud, const FusedSet& set) const {
    StampBlame b;
    bool warned = topic_flagged(kFusedCloudTopic, cloud != nullptr ? cloud->out_ns() : set.stamp);
    for (const auto& m : members)
      if (const std::string e = own_stamp_error(m); !e.empty()) {
        b.why += (b.why.empty() ? "its stamps put them in one: " : ", ") + e;
        warned = warned && topic_flagged(m.lidar->topic, m.scan->out_ns());
      }
    b.warned = !b.why.empty() && warned;
    return b;
  }

  // A member's flag is held against when it went out (SampleRecord::out_ns), not its stamp.
  bool flagged(const std::vector<Member>& members) const {
    return std::any_of(members.begin(), members.end(), [&](const Member& m) { return topic_flagged(m.lidar->topic, m.scan->out_ns()); });
  }

  // Every scan a fused LIDAR published in the window: in exactly one sweep, or counted dropped.
  void account_scans() {
    std::uint64_t not_fused = 0;
    std::string first;
    for (std::size_t li = 0; li < lidars_.size(); ++li)
      for (const auto& [seq, s] : lidars_[li].by_seq) {
        if (!in_window(s->acquisition_ns)) continue;
        ++t_.sent;
        const auto it = fused_in_.find({li, seq});
        if (it == fused_in_.end()) {
          ++not_fused;
          if (first.empty()) first = lidars_[li].name + " seq " + std::to_string(seq) + " at " + ctx_.at_s(s->acquisition_ns) + " s";
          continue;
        }
        if (it->second.size() > 1) {
          ++t_.published_twice;
          std::string sweeps;
          for (const auto n : it->second) sweeps += (sweeps.empty() ? "" : " and ") + std::to_string(n);
          fail("fused_twice", lidars_[li].name + " seq " + std::to_string(seq) + " fused into sweeps " + sweeps);
        }
        const auto c = complete_.find(it->second.front());
        ++(c != complete_.end() && c->second ? t_.published_complete : t_.published_incomplete);
      }
    t_.counted_lost = std::min(in_.fused.scans_dropped, not_fused);
    t_.unaccounted = not_fused - t_.counted_lost;
    if (t_.unaccounted > 0)
      fail("unaccounted", std::to_string(t_.unaccounted) + " scans published by the LIDARs neither fused nor counted dropped by fusion (" +
           std::to_string(in_.fused.scans_dropped) + " counted); first: " + first);
  }

  // Every fused cloud says its members.
  void unpaired_clouds() {
    for (const auto& [seq, s] : clouds_) {
      if (!in_window(s->acquisition_ns) || sets_.contains(seq)) continue;
      ++t_.unmatched;
      fail("no_members", "fused cloud seq " + std::to_string(seq) + " (stamped at " + ctx_.at_s(s->acquisition_ns) + " s) has no members on /rig/sets/fused");
    }
  }

  // The monitor's record of the fused cloud holds one sample (received or lost) per sweep published.
  void check_monitor() {
    if (const auto m = in_.monitor.find(kFusedCloudTopic); m != in_.monitor.end()) {
      t_.monitor_received = m->second.received;
      t_.monitor_lost = m->second.lost;
    }
    if (clouds_.empty()) {
      if (!in_.fused.sets.empty()) ctx_.violation("monitor_agrees", kFusedCloudTopic, "the monitor saw no fused cloud; " +
                                                  std::to_string(in_.fused.sets.size()) + " sweeps were published");
      return;
    }
    Nanos a = in_.window_begin_ns, b = in_.window_end_ns, first = INT64_MAX, last = INT64_MIN;
    for (const auto& [seq, s] : clouds_) {
      first = std::min(first, s->acquisition_ns);
      last = std::max(last, s->acquisition_ns);
    }
    a = std::max(a, first);
    b = std::min(b, last + 1);
    std::uint64_t made = 0, seen = 0;
    for (const auto& set : in_.fused.sets)
      if (set.stamp >= a && set.stamp < b && !ctx_.doubled(set.stamp)) ++made;
    for (const auto& [seq, s] : clouds_)
      if (s->acquisition_ns >= a && s->acquisition_ns < b && !ctx_.doubled(s->acquisition_ns)) ++seen;
    t_.monitor_expected = made;
    if (seen != made)
      ctx_.violation("monitor_agrees", kFusedCloudTopic, "monitor: " + std::to_string(seen) + " fused clouds received or lost; " +
                                                             std::to_string(made) + " sweeps were published while it watched");
  }

  const Input& in_;
  const JudgeContext& ctx_;
  TopicResult& t_;
  const Nanos period_;
  Nanos pieces_from_ = 0;
  std::vector<Nanos> boundaries_;  // per piece of piece_ from pieces_from_ (not wrapped)
  std::vector<std::optional<Nanos>> tied_;  // per piece: the boundary in a gap as wide (tied_boundary)
  std::vector<Lidar> lidars_;
  std::map<std::string, std::size_t> lidar_of_;
  std::map<std::uint64_t, const SampleRecord*> clouds_;                          // fused clouds by seq
  std::set<std::uint64_t> sets_;                                                 // seqs of the members sets
  std::map<std::pair<std::size_t, std::uint64_t>, std::vector<std::uint64_t>> fused_in_;  // (lidar, seq) -> sweeps
  std::map<std::uint64_t, bool> complete_;                                       // sweep -> its stamps say complete
  std::vector<std::pair<Nanos, std::uint64_t>> whole_;                           // (stamp, seq) of sweeps complete with every LIDAR
  std::vector<double> errors_;
  struct Kind {
    std::string kind, first;
    std::uint64_t count = 0;
  };
  std::vector<Kind> kinds_;
};

}  // namespace

void check_fused(const Input& in, const JudgeContext& ctx, Result& r) { FusedJudge(in, ctx, r).run(); }

}  // namespace sensor_rig::rig::chaos
