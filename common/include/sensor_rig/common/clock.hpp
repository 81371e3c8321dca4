#pragma once
// Clock reads live here and in timesync/ only; decoders take time as arguments.
#include <time.h>

#include <cstdint>
#include <cstdlib>

namespace sensor_rig {

using Nanos = std::int64_t;  // signed ns; vehicle time is CLOCK_REALTIME (SPEC §6)

// Units of Nanos, for periods, schedules and bounds written as 20 * kMs rather than 20'000'000.
inline constexpr Nanos kUs = 1'000;
inline constexpr Nanos kMs = 1'000'000;
inline constexpr Nanos kSec = 1'000'000'000;

inline Nanos clock_ns(clockid_t id) noexcept {
  timespec ts{};
  ::clock_gettime(id, &ts);
  return static_cast<Nanos>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}
inline Nanos vehicle_now_ns() noexcept { return clock_ns(CLOCK_REALTIME); }
inline Nanos monotonic_now_ns() noexcept { return clock_ns(CLOCK_MONOTONIC); }

// Vehicle time and CLOCK_MONOTONIC at one instant, for every place that turns one into the other.
// Two bare reads are as far apart as any preemption between them: on a loaded host 1.26 ms once in
// ten minutes, which put a fake V4L2 camera's truth 1.26 ms off its frame (ten-minute campaign,
// seed 4: `stamps` broken by the mock) and is a "step" to a 1 ms CLOCK_REALTIME step detector. So
// the realtime read is bracketed by two monotonic ones and paired with their midpoint; of up to
// four tries the tightest is kept, and a bracket within 20 us (no preemption) ends the search.
struct ClockPair {
  Nanos vehicle_ns = 0;
  Nanos monotonic_ns = 0;
  [[nodiscard]] Nanos vehicle_minus_monotonic() const noexcept { return vehicle_ns - monotonic_ns; }
};
// The pairing itself, on any two clock reads (tests script preemptions into them).
template <class ReadMonotonic, class ReadVehicle>
ClockPair tightest_clock_pair(ReadMonotonic&& read_monotonic, ReadVehicle&& read_vehicle) noexcept {
  ClockPair best;
  Nanos best_width = -1;
  for (int attempt = 0; attempt < 4; ++attempt) {
    const Nanos before = read_monotonic();
    const Nanos vehicle = read_vehicle();
    const Nanos after = read_monotonic();
    if (best_width < 0 || after - before < best_width) {
      best_width = after - before;
      best = {vehicle, before + best_width / 2};
    }
    if (best_width <= 20 * kUs) break;
  }
  return best;
}
inline ClockPair clock_pair_now() noexcept { return tightest_clock_pair(monotonic_now_ns, vehicle_now_ns); }

// A mock started while `rig chaos` holds CLOCK_REALTIME stepped (host.clock_step) takes the step off
// what it reads: its device's clock (a PTP-synced sensor's grandmaster) is vehicle time, which the
// host's step does not move. Mocks started before the step anchor their clocks then and keep them;
// one restarted during it (host.kill_mock) read the stepped time and kept it: a left OS-LEGACY 37 s
// behind the truth for the rest of a campaign (rig chaos seed 9 with drawn parameters), its scans
// taken for ones sent 37 s later. `rig up` sets the step in force for a mock it restarts
// (MockFaults); unset (every other start) it is 0.
inline constexpr const char* kMockHostStepEnv = "RIG_MOCK_HOST_STEP_NS";
inline Nanos mock_host_step_ns() noexcept {
  const char* v = std::getenv(kMockHostStepEnv);
  return v == nullptr ? 0 : static_cast<Nanos>(std::strtoll(v, nullptr, 10));
}
inline ClockPair mock_clock_pair_now() noexcept {
  ClockPair p = clock_pair_now();
  p.vehicle_ns -= mock_host_step_ns();
  return p;
}

}  // namespace sensor_rig
