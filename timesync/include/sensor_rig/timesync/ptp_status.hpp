#pragma once
// linuxptp status for diagnostics: a pure parser of `pmc -u -b 0 'GET TIME_STATUS_NP'` output.
// No process is run here; the caller captures the text (and its own timeout) and passes it in.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::timesync {

struct PtpTimeStatus {
  std::string port_identity;   // responding port, e.g. "90e2ba.fffe.20c7f8-0"
  std::int64_t master_offset_ns = 0;
  std::int64_t ingress_time_ns = 0;
  double cumulative_scaled_rate_offset = 0.0;
  std::int64_t scaled_last_gm_phase_change = 0;
  std::int64_t gm_time_base_indicator = 0;
  std::string last_gm_phase_change;  // as printed, e.g. "0x0000'0000000000000000.0000"
  bool gm_present = false;
  std::string gm_identity;           // e.g. "0050c2.fffe.d0d000"
};

enum class PtpParseStatus : std::uint8_t {
  kOk = 0,
  kNoResponse,   // only the "sending:" line (ptp4l not running, or timed out)
  kMalformed,    // a TIME_STATUS_NP response with a missing or unreadable field
};
const char* to_string(PtpParseStatus s) noexcept;

struct PtpParseResult {
  PtpParseStatus status = PtpParseStatus::kNoResponse;
  std::vector<PtpTimeStatus> responses;  // one per responding port (usually one)
  std::string error;                     // what was wrong, with the line number
};

PtpParseResult parse_pmc_time_status(std::string_view text);

// Summary for diagnostics: synchronised when a grandmaster is present and |offset| <= limit.
bool ptp_synchronised(const PtpTimeStatus& s, std::int64_t max_offset_ns) noexcept;

}  // namespace sensor_rig::timesync
