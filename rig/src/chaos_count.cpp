#include "chaos_count.hpp"

#include <algorithm>

namespace sensor_rig::rig::chaos {

CountVerdict reconcile_count(const CountFacts& f) {
  CountVerdict v;
  v.doubled_lost = f.doubled_made > f.doubled_samples ? f.doubled_made - f.doubled_samples : 0;
  // edge_in counts units inside the window, all of them among not_published.
  const std::uint64_t least = f.not_published - std::min(f.edge_in + f.unseeable, f.not_published) + v.doubled_lost;
  v.most = f.not_published + f.edge_out + v.doubled_lost + f.silent_slots;
  v.over_counted = f.rig_counted > v.most;
  v.over_unheard = f.rig_unheard > f.unheard_units + f.turns_unmade;
  const std::uint64_t unheard = std::min(f.rig_unheard, f.unheard_units);
  const std::uint64_t counted = std::min(f.rig_counted + unheard, v.most);
  v.unaccounted_all = least > counted ? least - counted : 0;
  // What the count leaves open is the judged units' first (`sent` leaves doubled time out).
  v.unaccounted = std::min(f.not_published, v.unaccounted_all);
  const std::uint64_t covered = f.not_published - v.unaccounted;
  v.counted_unheard = std::min(unheard, covered);
  v.counted_lost = covered - v.counted_unheard;
  return v;
}

}  // namespace sensor_rig::rig::chaos
