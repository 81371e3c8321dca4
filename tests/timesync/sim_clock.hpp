#pragma once
// Test helper: a synthetic device clock (offset + drift + steps) observed through a link with
// positive heavy-tailed delay. Everything is driven by a seeded engine: runs are reproducible.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::timesync::test {

struct DelayModel {
  Nanos base_ns = 150'000;       // minimum transport delay
  double exp_mean_ns = 200'000;  // scheduling / queueing jitter
  double tail_prob = 0.01;       // Pareto tail (interrupt storms, GC pauses of the sender)
  double tail_min_ns = 1'000'000;
  double tail_alpha = 1.5;
  double tail_cap_ns = 40'000'000;
  double early_prob = 0.0;       // impossible "negative delay" glitches (host clock bugs)
  Nanos early_ns = -8'000'000;
};

class SimLink {
 public:
  SimLink(std::uint64_t seed, DelayModel m) : rng_(seed), m_(m) {}

  Nanos delay() {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    if (m_.early_prob > 0 && u(rng_) < m_.early_prob) return m_.early_ns;
    double d = static_cast<double>(m_.base_ns);
    d += std::exponential_distribution<double>(1.0 / m_.exp_mean_ns)(rng_);
    if (u(rng_) < m_.tail_prob) {
      const double p = m_.tail_min_ns / std::pow(1.0 - u(rng_), 1.0 / m_.tail_alpha);
      d += std::min(p, m_.tail_cap_ns);
    }
    return static_cast<Nanos>(std::llround(d));
  }
  std::mt19937_64& rng() { return rng_; }

 private:
  std::mt19937_64 rng_;
  DelayModel m_;
};

// device(t) = device0 + (t - t0) * (1 + drift) + step (after the step was applied).
struct SimDevice {
  Nanos t0 = 1'700'000'000'000'000'000;  // vehicle time at device0
  Nanos device0 = 42'000'000'000;        // arbitrary epoch (e.g. seconds since power-on)
  double drift_ppm = 0.0;
  Nanos step_ns = 0;

  Nanos device_at(Nanos t) const {
    const double dt = static_cast<double>(t - t0);
    return device0 + static_cast<Nanos>(std::llround(dt * (1.0 + drift_ppm * 1e-6))) + step_ns;
  }
  Nanos vehicle_at(Nanos device) const {  // inverse of device_at
    const double dd = static_cast<double>(device - device0 - step_ns);
    return t0 + static_cast<Nanos>(std::llround(dd / (1.0 + drift_ppm * 1e-6)));
  }
};

}  // namespace sensor_rig::timesync::test
