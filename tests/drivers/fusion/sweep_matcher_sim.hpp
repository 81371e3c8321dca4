#pragma once
// The sweep matcher's simulated rig (test_sweep_matcher*.cpp): phase-locked LIDARs whose scans'
// rotations are known (rotation n of LIDAR s stamped n * period + phase_s), handed to the matcher
// in arrival order as the node does, polled at every deadline; what it emitted held against the
// truth. Its own namespace: beside the other fusion tests in one unity batch.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

namespace sensor_rig::drivers::sim {

inline constexpr Nanos kPeriod = 100 * kMs;
inline constexpr Nanos kTimeout = 150 * kMs;
inline constexpr Nanos kDelivery = kPeriod + 2 * kMs;  // a scan is handed over one rotation + 2 ms after its first firing

struct TrueScan {
  std::uint32_t source = 0;
  std::int64_t rotation = 0;  // the truth
  Nanos stamp = 0;            // what the LIDAR stamped (vehicle time: steps with the clock)
  Nanos arrival = 0;          // handed to the node (monotonic)
  Nanos span = 0;             // its last point's time after its stamp (0: not told, one period)
  std::int64_t rotations = 1;  // the truth: rotations of the rig's period it spans (2: 300 rpm beside 600)
};

struct Emitted {
  Nanos at = 0;
  bool complete = false;
  std::vector<TrueScan> scans;
};

// Scans of `rotations` [first, last) for LIDARs at `phases`, delivered kDelivery after their stamp.
inline std::vector<TrueScan> rig_scans(const std::vector<Nanos>& phases, std::int64_t first, std::int64_t last) {
  std::vector<TrueScan> v;
  for (std::int64_t n = first; n < last; ++n)
    for (std::uint32_t s = 0; s < phases.size(); ++s) {
      const Nanos stamp = n * kPeriod + phases[s];
      v.push_back({s, n, stamp, stamp + kDelivery});
    }
  return v;
}

inline void erase_scans(std::vector<TrueScan>& v, std::uint32_t source, std::int64_t from, std::int64_t to) {
  std::erase_if(v, [&](const TrueScan& t) { return t.source == source && t.rotation >= from && t.rotation < to; });
}

inline TrueScan& find_scan(std::vector<TrueScan>& v, std::uint32_t source, std::int64_t rotation) {
  for (auto& t : v)
    if (t.source == source && t.rotation == rotation) return t;
  throw std::logic_error("no such scan");
}

// The node's loop on simulated time: scans in arrival order (each source's in order), ready()
// after each and at every deadline in between.
class SimulatedRig {
 public:
  explicit SimulatedRig(std::uint32_t sources) : m_({sources, kPeriod, kTimeout}), sources_(sources) {}

  void feed(std::vector<TrueScan> scans) {
    std::map<std::uint32_t, Nanos> last;  // a source's scans arrive in order
    for (auto& t : scans) {
      t.arrival = std::max(t.arrival, last[t.source]);
      last[t.source] = t.arrival;
    }
    std::stable_sort(scans.begin(), scans.end(), [](const TrueScan& a, const TrueScan& b) { return a.arrival < b.arrival; });
    fed_.insert(fed_.end(), scans.begin(), scans.end());
    for (const auto& t : scans) {
      advance(t.arrival);
      const auto place = m_.push(t.source, t.stamp, t.arrival, t.span);
      if (place.late)
        dropped_.push_back(t);
      else
        open_[place.sweep].push_back(t);
      drain(t.arrival);
    }
    if (!scans.empty()) advance(scans.back().arrival + 10 * kTimeout);
  }

  // Every emitted sweep holds one rotation, says complete exactly when it has every source, and
  // every scan fed is emitted or dropped.
  void expect_truth(std::size_t fed) const {
    std::size_t seen = dropped_.size();
    for (const auto& e : emitted_) {
      ASSERT_FALSE(e.scans.empty());
      std::set<std::uint32_t> sources;
      for (const auto& t : e.scans) {
        EXPECT_EQ(t.rotation, e.scans[0].rotation) << "sweep emitted at " << e.at / kMs << " ms mixes rotations "
                                                  << e.scans[0].rotation << " and " << t.rotation;
        sources.insert(t.source);
      }
      EXPECT_EQ(sources.size(), e.scans.size());
      // Complete exactly when every source is in, or its scan that began in an earlier rotation
      // spans this one (a slower LIDAR: nothing of that time is missing).
      std::size_t covered = 0;
      for (std::uint32_t src = 0; src < sources_; ++src)
        if (!sources.contains(src) && spanned_by_earlier(src, e.scans[0].rotation)) ++covered;
      EXPECT_EQ(e.complete, sources.size() + covered == sources_) << "rotation " << e.scans[0].rotation;
      seen += e.scans.size();
    }
    EXPECT_EQ(seen, fed);
    EXPECT_TRUE(open_.empty());
  }

  // The emitted sweep holding rotation n's scans (the first, when split), or nullptr.
  [[nodiscard]] const Emitted* sweep_of(std::int64_t n) const {
    for (const auto& e : emitted_)
      if (e.scans[0].rotation == n) return &e;
    return nullptr;
  }
  // How long after its last scan arrived a rotation's sweep went out.
  [[nodiscard]] Nanos wait_of(std::int64_t n) const {
    const Emitted* e = sweep_of(n);
    if (e == nullptr) return -1;
    Nanos last = 0;
    for (const auto& t : e->scans) last = std::max(last, t.arrival);
    return e->at - last;
  }

  // A scan of `source` that began before rotation n spans it, and is in the cloud (a scan dropped
  // as late covers nothing).
  [[nodiscard]] bool spanned_by_earlier(std::uint32_t source, std::int64_t n) const {
    const auto dropped = [&](const TrueScan& t) {
      return std::any_of(dropped_.begin(), dropped_.end(), [&](const TrueScan& d) { return d.source == t.source && d.stamp == t.stamp; });
    };
    return std::any_of(fed_.begin(), fed_.end(), [&](const TrueScan& t) {
      return t.source == source && t.rotation < n && n < t.rotation + t.rotations && !dropped(t);
    });
  }

  SweepMatcher m_;
  std::uint32_t sources_;
  std::vector<TrueScan> fed_;
  std::map<std::uint64_t, std::vector<TrueScan>> open_;
  std::vector<Emitted> emitted_;
  std::vector<TrueScan> dropped_;

 private:
  void drain(Nanos now) {
    while (auto c = m_.ready(now)) {
      auto it = open_.find(c->id);
      ASSERT_NE(it, open_.end()) << "sweep " << c->id << " was never given a scan";
      std::size_t present = 0;
      for (bool p : c->present) present += p ? 1 : 0;
      EXPECT_EQ(present, it->second.size());
      emitted_.push_back({now, c->complete, std::move(it->second)});
      open_.erase(it);
    }
  }
  void advance(Nanos to) {
    for (Nanos d = m_.deadline(); d >= 0 && d <= to; d = m_.deadline()) drain(d);
  }
};

inline const std::vector<Nanos> kPhases{0, 20 * kMs, 45 * kMs};  // the widest gap: 45 -> 100 ms

// Emitted sweeps holding scans of more than one true rotation.
inline std::size_t mixed_sweeps(const SimulatedRig& run) {
  return static_cast<std::size_t>(std::count_if(run.emitted_.begin(), run.emitted_.end(), [](const Emitted& e) {
    return std::any_of(e.scans.begin(), e.scans.end(), [&](const TrueScan& t) { return t.rotation != e.scans[0].rotation; });
  }));
}

}  // namespace sensor_rig::drivers::sim
