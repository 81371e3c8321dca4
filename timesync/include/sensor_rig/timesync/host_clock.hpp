#pragma once
// The host clock (vehicle time = CLOCK_REALTIME of the PU): steps while running and PTP state.
// Pure: the caller reads the clocks / runs pmc and passes the results in (tests inject them).
#include <cstdint>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/timesync/ptp_status.hpp"

namespace sensor_rig::timesync {

// CLOCK_REALTIME steps (NTP/PTP corrections, `date -s`): between two observations, realtime must
// advance as much as monotonic; a difference beyond the threshold is a step (slewing at <= 500 ppm
// stays far below it at any sensible observation period).
class RealtimeStepDetector {
 public:
  explicit RealtimeStepDetector(Nanos threshold_ns = 1'000'000) noexcept : threshold_ns_(threshold_ns) {}
  // Returns the step (realtime delta - monotonic delta) when one is detected, else 0.
  Nanos observe(Nanos realtime_ns, Nanos monotonic_ns) noexcept;
  [[nodiscard]] std::uint64_t steps() const noexcept { return steps_; }
  [[nodiscard]] Nanos last_step_ns() const noexcept { return last_step_ns_; }
  [[nodiscard]] Nanos total_step_ns() const noexcept { return total_step_ns_; }

 private:
  Nanos threshold_ns_;
  bool have_ = false;
  Nanos last_rt_ = 0, last_mono_ = 0;
  std::uint64_t steps_ = 0;
  Nanos last_step_ns_ = 0, total_step_ns_ = 0;
};

enum class HostSyncState : std::uint8_t {
  kNotSynchronized,  // no linuxptp here (no pmc, or ptp4l not answering): free-running host clock
  kUnsynchronized,   // ptp4l answers, but no grandmaster or the offset is beyond the limit
  kSynchronized,     // grandmaster present and |master offset| <= limit
  kError,            // pmc output unreadable
};
const char* to_string(HostSyncState s) noexcept;

struct HostSyncStatus {
  HostSyncState state = HostSyncState::kNotSynchronized;
  std::string reason;              // one line for /diagnostics
  std::int64_t master_offset_ns = 0;
  std::string gm_identity;
};

// From `pmc -u -b 0 'GET TIME_STATUS_NP'`: pmc_ran=false when pmc is not installed or timed out.
HostSyncStatus host_sync_status(bool pmc_ran, std::string_view pmc_output, std::int64_t max_offset_ns = 1000);

}  // namespace sensor_rig::timesync
