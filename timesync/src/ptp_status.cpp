#include "sensor_rig/timesync/ptp_status.hpp"

#include <charconv>
#include <cstdint>
#include <optional>

namespace sensor_rig::timesync {

namespace {

constexpr std::string_view kTlv = "TIME_STATUS_NP";

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

// Splits "key   value" at the first run of blanks.
bool split_kv(std::string_view line, std::string_view& key, std::string_view& value) {
  const auto sp = line.find_first_of(" \t");
  if (sp == std::string_view::npos) return false;
  key = line.substr(0, sp);
  value = trim(line.substr(sp));
  return !value.empty();
}

std::optional<std::int64_t> to_int(std::string_view v) {
  if (!v.empty() && v.front() == '+') v.remove_prefix(1);
  std::int64_t out = 0;
  const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  if (ec != std::errc{} || p != v.data() + v.size()) return std::nullopt;
  return out;
}

std::optional<double> to_double(std::string_view v) {
  if (!v.empty() && v.front() == '+') v.remove_prefix(1);
  double out = 0;
  const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  if (ec != std::errc{} || p != v.data() + v.size()) return std::nullopt;
  return out;
}

struct Pending {
  PtpTimeStatus s;
  bool offset = false, ingress = false, present = false, identity = false;
  std::size_t line = 0;
};

}  // namespace

const char* to_string(PtpParseStatus s) noexcept {
  switch (s) {
    case PtpParseStatus::kOk: return "ok";
    case PtpParseStatus::kNoResponse: return "no_response";
    case PtpParseStatus::kMalformed: return "malformed";
  }
  return "unknown";
}

bool ptp_synchronised(const PtpTimeStatus& s, std::int64_t max_offset_ns) noexcept {
  if (!s.gm_present) return false;
  const std::int64_t o = s.master_offset_ns;
  const std::int64_t mag = o == INT64_MIN ? INT64_MAX : (o < 0 ? -o : o);
  return mag <= max_offset_ns;
}

PtpParseResult parse_pmc_time_status(std::string_view text) {
  PtpParseResult r;
  std::optional<Pending> cur;
  bool in_other_tlv = false;
  auto fail = [&](std::size_t line, const std::string& what) {
    if (r.error.empty()) r.error = "line " + std::to_string(line) + ": " + what;
  };
  auto finish = [&]() {
    if (!cur) return;
    if (!cur->offset || !cur->ingress || !cur->present || !cur->identity) {
      fail(cur->line, "TIME_STATUS_NP response lacks master_offset, ingress_time, gmPresent or "
                      "gmIdentity");
    } else {
      r.responses.push_back(std::move(cur->s));
    }
    cur.reset();
  };

  std::size_t lineno = 0;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    const std::string_view raw = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++lineno;
    const std::string_view line = trim(raw);
    if (line.empty() || line.starts_with("sending:")) continue;

    // Response header: "<portIdentity> seq <n> RESPONSE MANAGEMENT <TLV>" (or an error status).
    if (line.find(" seq ") != std::string_view::npos &&
        (line.find("RESPONSE") != std::string_view::npos ||
         line.find("MANAGEMENT_ERROR_STATUS") != std::string_view::npos)) {
      finish();
      in_other_tlv = false;
      if (line.find("MANAGEMENT_ERROR_STATUS") != std::string_view::npos) {
        fail(lineno, "management error: " + std::string(line));
        in_other_tlv = true;
        continue;
      }
      const auto last_sp = line.find_last_of(" \t");
      if (line.substr(last_sp + 1) != kTlv) {
        in_other_tlv = true;  // another TLV in the same output: not ours, skip its fields
        continue;
      }
      cur.emplace();
      cur->line = lineno;
      cur->s.port_identity = std::string(line.substr(0, line.find_first_of(" \t")));
      continue;
    }
    if (in_other_tlv) continue;
    if (!cur) {
      fail(lineno, "unexpected text outside a response: '" + std::string(line) + "'");
      continue;
    }
    std::string_view key, value;
    if (!split_kv(line, key, value)) {
      fail(lineno, "expected 'name value': '" + std::string(line) + "'");
      continue;
    }
    const std::string k(key);
    bool ok = true;
    if (k == "master_offset") {
      const auto v = to_int(value);
      ok = v.has_value();
      cur->s.master_offset_ns = v.value_or(0);
      cur->offset = ok;
    } else if (k == "ingress_time") {
      const auto v = to_int(value);
      ok = v.has_value();
      cur->s.ingress_time_ns = v.value_or(0);
      cur->ingress = ok;
    } else if (k == "cumulativeScaledRateOffset") {
      const auto v = to_double(value);
      ok = v.has_value();
      cur->s.cumulative_scaled_rate_offset = v.value_or(0.0);
    } else if (k == "scaledLastGmPhaseChange") {
      const auto v = to_int(value);
      ok = v.has_value();
      cur->s.scaled_last_gm_phase_change = v.value_or(0);
    } else if (k == "gmTimeBaseIndicator") {
      const auto v = to_int(value);
      ok = v.has_value();
      cur->s.gm_time_base_indicator = v.value_or(0);
    } else if (k == "lastGmPhaseChange") {
      cur->s.last_gm_phase_change = std::string(value);
    } else if (k == "gmPresent") {
      ok = value == "true" || value == "false";
      cur->s.gm_present = value == "true";
      cur->present = ok;
    } else if (k == "gmIdentity") {
      cur->s.gm_identity = std::string(value);
      cur->identity = true;
    }  // other names: newer linuxptp fields, ignored
    if (!ok) fail(lineno, "bad value for " + k + ": '" + std::string(value) + "'");
  }
  finish();
  if (!r.error.empty()) {
    r.status = PtpParseStatus::kMalformed;
  } else {
    r.status = r.responses.empty() ? PtpParseStatus::kNoResponse : PtpParseStatus::kOk;
  }
  return r;
}

}  // namespace sensor_rig::timesync
