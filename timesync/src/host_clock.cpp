#include "sensor_rig/timesync/host_clock.hpp"

namespace sensor_rig::timesync {

Nanos RealtimeStepDetector::observe(Nanos realtime_ns, Nanos monotonic_ns) noexcept {
  if (!have_) {
    have_ = true;
    last_rt_ = realtime_ns;
    last_mono_ = monotonic_ns;
    return 0;
  }
  const Nanos step = (realtime_ns - last_rt_) - (monotonic_ns - last_mono_);
  last_rt_ = realtime_ns;
  last_mono_ = monotonic_ns;
  if (step > threshold_ns_ || step < -threshold_ns_) {
    ++steps_;
    last_step_ns_ = step;
    total_step_ns_ += step;
    return step;
  }
  return 0;
}

const char* to_string(HostSyncState s) noexcept {
  switch (s) {
    case HostSyncState::kNotSynchronized: return "not synchronized";
    case HostSyncState::kUnsynchronized: return "unsynchronized";
    case HostSyncState::kSynchronized: return "synchronized";
    case HostSyncState::kError: return "error";
  }
  return "?";
}

HostSyncStatus host_sync_status(bool pmc_ran, std::string_view pmc_output, std::int64_t max_offset_ns) {
  HostSyncStatus h;
  if (!pmc_ran) {
    h.reason = "no linuxptp (pmc not found or not answering): host clock free-running";
    return h;
  }
  const PtpParseResult r = parse_pmc_time_status(pmc_output);
  if (r.status == PtpParseStatus::kNoResponse) {
    h.reason = "ptp4l not running (pmc got no response): host clock free-running";
    return h;
  }
  if (r.status == PtpParseStatus::kMalformed || r.responses.empty()) {
    h.state = HostSyncState::kError;
    h.reason = "pmc output unreadable: " + r.error;
    return h;
  }
  const PtpTimeStatus& s = r.responses.front();
  h.master_offset_ns = s.master_offset_ns;
  h.gm_identity = s.gm_identity;
  if (ptp_synchronised(s, max_offset_ns)) {
    h.state = HostSyncState::kSynchronized;
    h.reason = "PTP: grandmaster " + s.gm_identity + ", offset " + std::to_string(s.master_offset_ns) + " ns";
  } else {
    h.state = HostSyncState::kUnsynchronized;
    h.reason = s.gm_present ? "PTP: offset " + std::to_string(s.master_offset_ns) + " ns beyond " +
                                  std::to_string(max_offset_ns) + " ns"
                            : std::string("PTP: no grandmaster");
  }
  return h;
}

}  // namespace sensor_rig::timesync
