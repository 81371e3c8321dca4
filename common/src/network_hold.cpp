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

Nanos NetworkHold::hold_for(std::size_t i, Nanos now) {
  const Window& w = windows_[i];
  if (w.jitter_ns <= 0) return w.delay_ns;
  const Nanos lo = std::max<Nanos>(0, w.delay_ns - w.jitter_ns), hi = w.delay_ns + w.jitter_ns;
  std::uniform_int_distribution<Nanos> draw(lo, hi);
  Walk& k = walks_[i];
  Nanos budget = (now - k.last_in) / 2;  // falls by at most half the time since the last datagram
  k.last_in = now;
  if (!k.started || budget >= hi - lo) {
    k.started = true;
    k.hold = draw(rng_);
    k.target = draw(rng_);
    return k.hold;
  }
  while (budget > 0) {
    const Nanos step = std::min(budget, std::abs(k.target - k.hold));
    k.hold += k.target > k.hold ? step : -step;
    budget -= step;
    if (k.hold == k.target) k.target = draw(rng_);
  }
  return k.hold;
}

NetworkHold::Due NetworkHold::due(Nanos now) {
  Due d{now, 0};
  for (std::size_t i = 0; i < windows_.size(); ++i)
    if (now >= windows_[i].from_mono && now < windows_[i].until_mono) {
      d.at_mono = std::max(d.at_mono, now + hold_for(i, now));
      d.fault = windows_[i].id;
    }
  d.at_mono = std::max(d.at_mono, held_until_);
  if (d.at_mono > now) held_until_ = d.at_mono;
  return d;
}

}  // namespace sensor_rig::faults
