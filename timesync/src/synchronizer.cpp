#include "sensor_rig/timesync/synchronizer.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace sensor_rig::timesync {
namespace {

constexpr Nanos kInf = std::numeric_limits<Nanos>::max();
constexpr std::uint32_t kMaxMembers = 64;

// Gaps of one member's options around the pivot: before = pivot - last stamp <= pivot, after =
// first stamp >= pivot - pivot; -1 = no such option.
struct Options {
  Nanos before = -1;
  Nanos after = -1;
};

struct Choice {
  Nanos spread = kInf;   // kInf = no set
  Nanos before_limit = 0;  // members whose before gap <= this take their before sample
};

// The set of smallest spread containing the pivot: the members with before gap <= D take their
// sample before the pivot, the others their sample after it; spread = D + the largest after gap
// of those. Minimised over D in {0} and every before gap. O(members^2), members <= 64 (~10 here).
Choice best_choice(const std::vector<Options>& opts) noexcept {
  Choice best;
  auto try_limit = [&](Nanos d) {
    Nanos after = 0;
    for (const auto& o : opts) {
      if (o.before >= 0 && o.before <= d) continue;
      if (o.after < 0) return;  // this member has nothing on either side within d
      after = std::max(after, o.after);
    }
    if (d + after < best.spread || (d + after == best.spread && d < best.before_limit)) best = {d + after, d};
  };
  try_limit(0);
  for (const auto& o : opts)
    if (o.before > 0) try_limit(o.before);
  return best;
}

}  // namespace

const char* to_string(SyncPolicy p) noexcept {
  switch (p) {
    case SyncPolicy::kExact: return "exact";
    case SyncPolicy::kApproximate: return "approximate";
  }
  return "?";
}

Synchronizer::Synchronizer(SyncConfig cfg) : cfg_(std::move(cfg)) {
  if (cfg_.members < 1 || cfg_.members > kMaxMembers) throw std::invalid_argument("synchronizer: 1 to 64 members");
  if (cfg_.max_spread_ns < 0) throw std::invalid_argument("synchronizer: negative max_spread");
  if (cfg_.timeout_ns <= 0) throw std::invalid_argument("synchronizer: timeout must be > 0");
  if (cfg_.max_queue < 1) throw std::invalid_argument("synchronizer: max_queue must be >= 1");
  if (!cfg_.min_interval_ns.empty() && cfg_.min_interval_ns.size() != cfg_.members)
    throw std::invalid_argument("synchronizer: min_interval_ns needs one value per member");
  if (cfg_.min_interval_ns.empty()) cfg_.min_interval_ns.assign(cfg_.members, 0);
  if (cfg_.max_jump_ns < 0) throw std::invalid_argument("synchronizer: negative max_jump");
  if (cfg_.max_jump_ns == 0) cfg_.max_jump_ns = cfg_.timeout_ns;
  if (cfg_.policy == SyncPolicy::kExact) cfg_.max_spread_ns = 0;
  members_.resize(cfg_.members);
  chosen_.assign(cfg_.members, -1);
  stats_.dropped_per_member.assign(cfg_.members, 0);
}

PushResult Synchronizer::push(const SyncSample& s, Nanos now_ns) noexcept {
  if (s.member >= members_.size()) return PushResult::kBadMember;
  Member& m = members_[s.member];
  if (m.held) {
    const SyncSample held = *m.held;
    m.held.reset();
    if (s.stamp_ns >= held.stamp_ns) {  // the member stays there: a step (a clock stepped), followed
      ++stats_.jumps;
      (void)accept(held, now_ns);
      return accept(s, now_ns);
    }
    // The member came back: the held stamp was a wild one (a glitch, a reordered device clock).
    ++stats_.implausible;
    ++stats_.dropped;
    ++stats_.dropped_per_member[s.member];
  }
  if (beyond_every_stamp(s.stamp_ns)) {
    m.held = s;
    return PushResult::kHeld;
  }
  return accept(s, now_ns);
}

bool Synchronizer::beyond_every_stamp(Nanos stamp) const noexcept {
  Nanos latest = kNone;
  for (const auto& m : members_) latest = std::max(latest, m.watermark);
  return latest != kNone && stamp - latest > cfg_.max_jump_ns;
}

PushResult Synchronizer::accept(const SyncSample& s, Nanos now_ns) noexcept {
  Member& m = members_[s.member];
  if (m.consumed != kNone && s.stamp_ns <= m.consumed) {
    ++stats_.late;
    return PushResult::kLate;
  }
  const auto pos = std::lower_bound(m.queue.begin(), m.queue.end(), s.stamp_ns,
                                    [](const SyncSample& a, Nanos t) { return a.stamp_ns < t; });
  if (pos != m.queue.end() && pos->stamp_ns == s.stamp_ns) {
    ++stats_.duplicates;
    return PushResult::kDuplicate;
  }
  ++stats_.pushed;
  m.queue.insert(pos, s);
  m.watermark = std::max(m.watermark, s.stamp_ns);
  while (m.queue.size() > cfg_.max_queue) {
    ++stats_.overflows;
    const SyncSample old = m.queue.front();
    m.queue.pop_front();
    m.consumed = std::max(m.consumed, old.stamp_ns);
    drop(s.member, old);
  }
  run(now_ns);
  return PushResult::kAccepted;
}

void Synchronizer::poll(Nanos now_ns) noexcept { run(now_ns); }

bool Synchronizer::pop(SyncSet& out) noexcept {
  if (ready_.empty()) return false;
  out = std::move(ready_.front());
  ready_.pop_front();
  return true;
}

void Synchronizer::run(Nanos now_ns) noexcept {
  for (;;) {
    const Decision d = decide(now_ns);
    if (d == Decision::kWait) return;
    if (d == Decision::kDropGroup) {
      for (std::uint32_t i = 0; i < members_.size(); ++i) {
        if (chosen_[i] < 0) continue;
        const Nanos stamp = members_[i].queue[static_cast<std::size_t>(chosen_[i])].stamp_ns;
        consume_through(i, stamp + 1);  // the group's sample too
      }
      continue;
    }
    if (d == Decision::kDropPivot) {
      Member& p = members_[pivot_member_];
      const SyncSample s = p.queue.front();
      p.queue.pop_front();
      p.consumed = std::max(p.consumed, s.stamp_ns);
      drop(pivot_member_, s);
      continue;
    }
    SyncSet set;
    set.samples.resize(members_.size());
    Nanos lo = kInf, hi = std::numeric_limits<Nanos>::min();
    for (std::uint32_t i = 0; i < members_.size(); ++i) {
      set.samples[i] = members_[i].queue[static_cast<std::size_t>(chosen_[i])];
      lo = std::min(lo, set.samples[i].stamp_ns);
      hi = std::max(hi, set.samples[i].stamp_ns);
    }
    set.first_ns = lo;
    set.spread_ns = hi - lo;
    for (std::uint32_t i = 0; i < members_.size(); ++i) consume_through(i, set.samples[i].stamp_ns);
    ++stats_.sets;
    ready_.push_back(std::move(set));
  }
}

// The pivot is the latest of the members' oldest samples: no set can hold an older sample of the
// pivot's member without skipping it, and every other member's candidates lie around it.
Synchronizer::Decision Synchronizer::decide(Nanos now_ns) noexcept {
  bool any = false;
  Nanos pivot = std::numeric_limits<Nanos>::min();
  for (std::uint32_t i = 0; i < members_.size(); ++i) {
    const auto& q = members_[i].queue;
    if (q.empty()) continue;
    if (!any || q.front().stamp_ns > pivot) {
      pivot = q.front().stamp_ns;
      pivot_member_ = i;
    }
    any = true;
  }
  if (!any) return Decision::kWait;

  // Options per member: real samples on either side; for the "optimistic" view a member without a
  // sample at or after the pivot may still get one, no earlier than watermark + min interval.
  thread_local std::vector<Options> real, optimistic;
  real.assign(members_.size(), Options{});
  optimistic.assign(members_.size(), Options{});
  for (std::uint32_t i = 0; i < members_.size(); ++i) {
    const Member& m = members_[i];
    const auto& q = m.queue;
    const auto it = std::lower_bound(q.begin(), q.end(), pivot,
                                     [](const SyncSample& a, Nanos t) { return a.stamp_ns < t; });
    Options o;
    if (it != q.end()) o.after = it->stamp_ns - pivot;
    if (it != q.end() && it->stamp_ns == pivot) {
      o.before = 0;
    } else if (it != q.begin()) {
      o.before = pivot - std::prev(it)->stamp_ns;
    }
    real[i] = o;
    Options v = o;
    if (v.after < 0) {
      const Nanos next = m.watermark == kNone ? pivot : m.watermark + cfg_.min_interval_ns[i];
      v.after = std::max<Nanos>(next - pivot, 0);
    }
    optimistic[i] = v;
  }
  const Choice best_real = best_choice(real);
  const Choice best_any = best_choice(optimistic);
  const Nanos limit = cfg_.max_spread_ns;

  auto choose = [&](const Choice& c) {
    for (std::uint32_t i = 0; i < members_.size(); ++i) {
      const auto& q = members_[i].queue;
      const auto it = std::lower_bound(q.begin(), q.end(), pivot,
                                       [](const SyncSample& a, Nanos t) { return a.stamp_ns < t; });
      const bool take_before = real[i].before >= 0 && real[i].before <= c.before_limit;
      const auto pick = take_before ? (it != q.end() && it->stamp_ns == pivot ? it : std::prev(it)) : it;
      chosen_[i] = pick - q.begin();
    }
    return Decision::kEmit;
  };

  // Final: no future sample can make a smaller set around the pivot.
  if (best_real.spread <= limit && best_real.spread <= best_any.spread) return choose(best_real);
  // Final: not even the most optimistic future makes a set within the limit.
  if (best_any.spread > limit) return Decision::kDropPivot;
  // A future sample could still make (a better) set: wait, up to the timeout.
  if (now_ns - members_[pivot_member_].queue.front().arrival_ns < cfg_.timeout_ns) return Decision::kWait;
  ++stats_.timeouts;
  if (best_real.spread <= limit) return choose(best_real);
  // Incomplete: the members that have a sample within the limit of the pivot go with it.
  for (std::uint32_t i = 0; i < members_.size(); ++i) {
    const auto& o = real[i];
    const auto& q = members_[i].queue;
    const auto it = std::lower_bound(q.begin(), q.end(), pivot,
                                     [](const SyncSample& a, Nanos t) { return a.stamp_ns < t; });
    const bool before_ok = o.before >= 0 && o.before <= limit;
    const bool after_ok = o.after >= 0 && o.after <= limit;
    if (before_ok && (!after_ok || o.before <= o.after)) {
      chosen_[i] = (it != q.end() && it->stamp_ns == pivot ? it : std::prev(it)) - q.begin();
    } else if (after_ok) {
      chosen_[i] = it - q.begin();
    } else {
      chosen_[i] = -1;
    }
  }
  return Decision::kDropGroup;
}

void Synchronizer::drop(std::uint32_t m, const SyncSample& s) noexcept {
  ++stats_.dropped;
  ++stats_.dropped_per_member[m];
  // Samples that made no set are counted as incomplete sets once per cluster (stamps within the
  // max spread of a recent cluster belong to the same missing set).
  for (const Nanos t : recent_incomplete_)
    if (t != kNone && (s.stamp_ns - t <= cfg_.max_spread_ns && t - s.stamp_ns <= cfg_.max_spread_ns)) return;
  ++stats_.incomplete;
  recent_incomplete_[recent_next_] = s.stamp_ns;
  recent_next_ = (recent_next_ + 1) % std::size(recent_incomplete_);
}

void Synchronizer::consume_through(std::uint32_t i, Nanos stamp) noexcept {
  Member& m = members_[i];
  while (!m.queue.empty() && m.queue.front().stamp_ns < stamp) {
    const SyncSample s = m.queue.front();
    m.queue.pop_front();
    drop(i, s);
  }
  if (!m.queue.empty() && m.queue.front().stamp_ns == stamp) m.queue.pop_front();
  m.consumed = std::max(m.consumed, stamp);
}

}  // namespace sensor_rig::timesync
