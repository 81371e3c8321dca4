// host.network_delay held in a mock (see network_hold.hpp).
#include "sensor_rig/common/network_hold.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace sensor_rig::faults {

NetworkHold::NetworkHold(std::vector<Window> windows, std::uint64_t seed)
    : windows_(std::move(windows)), walks_(windows_.size()), rng_(seed ^ 0x6a09e667f3bcc909ULL) {}

std::vector<NetworkHold::Window> NetworkHold::windows_of(const Plan& plan, const std::string& device) {
  std::vector<Window> out;
  for (const auto& e : plan.for_device(device)) {
    // Device "lo": netem holds the loopback (rig chaos decided so); no mock holds anything then.
    if (e.kind != "host.network_delay" || e.device == "lo") continue;
    Window w;
    w.id = e.id;
    w.from_mono = plan.epoch_mono_ns + static_cast<Nanos>(std::llround(e.at_s * 1e9));
    w.until_mono = plan.epoch_mono_ns + static_cast<Nanos>(std::llround((e.at_s + e.duration_s) * 1e9));
    w.delay_ns = std::max<Nanos>(0, static_cast<Nanos>(std::llround(e.number("ms", 50) * 1e6)));
    w.jitter_ns = std::max<Nanos>(0, static_cast<Nanos>(std::llround(e.number("jitter_ms", 0) * 1e6)));
    out.push_back(w);
  }
  return out;
}

Nanos HoldWalk::next(Nanos now, Nanos delay_ns, Nanos jitter_ns, std::mt19937_64& rng) {
  if (jitter_ns <= 0) return delay_ns;
  const Nanos lo = std::max<Nanos>(0, delay_ns - jitter_ns), hi = delay_ns + jitter_ns;
  std::uniform_int_distribution<Nanos> draw(lo, hi);
  Nanos budget = (now - last_in) / 2;  // falls by at most half the time since the last datagram
  last_in = now;
  if (!started || budget >= hi - lo) {  // the first datagram, or a gap long enough to reach any hold
    started = true;
    hold = draw(rng);
    target = draw(rng);
    return hold;
  }
  while (budget > 0) {
    const Nanos step = std::min(budget, std::abs(target - hold));
    hold += target > hold ? step : -step;
    budget -= step;
    if (hold == target) target = draw(rng);
  }
  return hold;
}

NetworkHold::Due NetworkHold::due(Nanos now) {
  Due d{now, 0};
  for (std::size_t i = 0; i < windows_.size(); ++i)
    if (now >= windows_[i].from_mono && now < windows_[i].until_mono) {
      d.at_mono = std::max(d.at_mono, now + walks_[i].next(now, windows_[i].delay_ns, windows_[i].jitter_ns, rng_));
      d.fault = windows_[i].id;
    }
  d.at_mono = std::max(d.at_mono, held_until_);
  if (d.at_mono > now) held_until_ = d.at_mono;
  return d;
}

}  // namespace sensor_rig::faults
