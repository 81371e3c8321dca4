#include "chaos_fused_rotations.hpp"

#include <algorithm>
#include <cstdlib>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::rig::chaos::fused {

Phases phases_between(const std::vector<Lidar>& lidars, Nanos period, Nanos from, Nanos to) {
  Phases ph;
  for (const auto& l : lidars) {
    const auto first = std::lower_bound(l.acqs.begin(), l.acqs.end(), std::make_pair(from, false));
    const auto last = std::lower_bound(first, l.acqs.end(), std::make_pair(to, false));
    ph.above.push_back(first != last && std::prev(last)->second ? 1 : 0);
    if (first == last || ph.above.back() != 0) {  // silent, or above the rig's rpm: no phase
      ph.of.emplace_back();
      continue;
    }
    ph.of.emplace_back(floor_mod(std::prev(last)->first, period));  // its latest scan's: the phase it is on
    ph.sorted.push_back(*ph.of.back());
  }
  std::sort(ph.sorted.begin(), ph.sorted.end());
  for (std::size_t i = 0; i < ph.sorted.size(); ++i) {
    const Nanos next = i + 1 < ph.sorted.size() ? ph.sorted[i + 1] : ph.sorted[0] + period;
    const Nanos gap = next - ph.sorted[i], middle = floor_mod(ph.sorted[i] + gap / 2, period);
    if (gap > ph.widest) {
      ph.second = ph.widest;
      ph.second_middle = ph.middle;
      ph.widest = gap;
      ph.middle = middle;
    } else if (gap > ph.second) {
      ph.second = gap;
      ph.second_middle = middle;
    }
  }
  return ph;
}

Nanos signed_mod(Nanos x, Nanos period) { return floor_mod(x + period / 2, period) - period / 2; }

std::optional<Nanos> tied_boundary(const Phases& ph, Nanos b, Nanos period) {
  if (ph.second < period / 4 || ph.widest - ph.second > period / 50) return std::nullopt;
  const Nanos to_widest = signed_mod(ph.middle - b, period), to_second = signed_mod(ph.second_middle - b, period);
  return b + (std::llabs(to_widest) >= std::llabs(to_second) ? to_widest : to_second);
}

bool a_lidar_moved(const Phases& before, const Phases& now, Nanos period) {
  for (std::size_t i = 0; i < now.of.size() && i < before.of.size(); ++i) {
    if (now.of[i] && before.of[i] && std::abs(signed_mod(*now.of[i] - *before.of[i], period)) > period / 8) return true;
    const bool present_now = now.of[i] || now.above[i] != 0, present_before = before.of[i] || before.above[i] != 0;
    if (present_now && present_before && now.above[i] != before.above[i]) return true;
  }
  return false;
}

std::optional<Nanos> rotation_boundary(const Phases& ph, bool anew, Nanos period, std::optional<Nanos> previous) {
  if (ph.sorted.empty()) return previous;
  if (!previous) return ph.middle;
  if (anew) return *previous + signed_mod(ph.middle - *previous, period);
  Nanos nearest = period;
  for (const Nanos p : ph.sorted) nearest = std::min<Nanos>(nearest, std::abs(signed_mod(p - *previous, period)));
  if (nearest >= ph.widest / 4) return previous;
  return *previous + signed_mod(ph.middle - *previous, period);
}

}  // namespace sensor_rig::rig::chaos::fused
