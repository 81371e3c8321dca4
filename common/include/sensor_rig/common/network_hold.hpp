#pragma once
// host.network_delay held in a mock (docs/faults.md "host.network_delay"): when each datagram (a
// GVSP packet of a camera fake, a CAN frame of the mock ECU) a mock hands to its network leaves,
// while a delay of the plan lasts. Each is held `ms` ± `jitter_ms` and none overtakes another: the
// hold walks between targets drawn uniformly from [ms - jitter_ms, ms + jitter_ms] (never below 0),
// falling by at most half the time since the previous datagram, as the LIDAR mocks' hold does
// (lidar/mock ScheduledFaults); datagrams after the fault leave behind the last held one, as a
// network's queue drains. Pure: times in (CLOCK_MONOTONIC ns), times out; no I/O.
#include <cstdint>
#include <random>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"

namespace sensor_rig::faults {

// The hold of one delay's datagrams: walks between targets drawn uniformly from [delay - jitter,
// delay + jitter] (never below 0), falling by at most half the time since the previous datagram, so
// that none overtakes another and each is held within delay ± jitter (independent draws kept in order
// would all wait behind the longest). The one walk of the LIDAR mocks (ScheduledFaults) and of the
// other mocks (NetworkHold).
struct HoldWalk {
  bool started = false;
  Nanos hold = 0, target = 0, last_in = 0;
  // The hold of a datagram handed over at `now` (calls in order of `now`).
  Nanos next(Nanos now, Nanos delay_ns, Nanos jitter_ns, std::mt19937_64& rng);
};

class NetworkHold {
 public:
  struct Window {
    std::uint64_t id = 0;  // the plan's event id
    Nanos from_mono = 0, until_mono = 0;
    Nanos delay_ns = 0, jitter_ns = 0;
  };
  struct Due {
    Nanos at_mono = 0;       // when the datagram leaves (>= the time it was handed over)
    std::uint64_t fault = 0; // the delay holding it (0: none; it may still queue behind held ones)
  };

  NetworkHold() = default;
  explicit NetworkHold(std::vector<Window> windows, std::uint64_t seed = 1);
  // The host.network_delay events of a plan (not netem's: device "lo"), timed by its epoch.
  static std::vector<Window> windows_of(const Plan& plan, const std::string& device);

  // A datagram handed over at `now_mono`: when it leaves. Calls come in order of `now_mono`.
  Due due(Nanos now_mono);
  [[nodiscard]] bool empty() const noexcept { return windows_.empty(); }
  [[nodiscard]] const std::vector<Window>& windows() const noexcept { return windows_; }

 private:
  std::vector<Window> windows_;
  std::vector<HoldWalk> walks_;
  std::mt19937_64 rng_;
  Nanos held_until_ = 0;  // the latest held datagram's departure: none after it leaves before it
};

}  // namespace sensor_rig::faults
