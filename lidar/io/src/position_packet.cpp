// Velodyne position packets and the NMEA RMC sentence they carry. Pure: no I/O, no clock.
#include "sensor_rig/lidar/velodyne/position_packet.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace sensor_rig::lidar::velodyne {
namespace {

constexpr Nanos kNsPerSec = 1'000'000'000LL;

// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
constexpr std::int64_t days_from_civil(int y, int m, int d) noexcept {
  y -= m <= 2 ? 1 : 0;
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return static_cast<std::int64_t>(era) * 146097 + doe - 719468;
}

struct Civil {
  int year, month, day;
};
constexpr Civil civil_from_days(std::int64_t z) noexcept {
  z += 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<int>(z - era * 146097);
  const int yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const int doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const int mp = (5 * doy + 2) / 153;
  const int d = doy - (153 * mp + 2) / 5 + 1;
  const int m = mp < 10 ? mp + 3 : mp - 9;
  const auto y = static_cast<int>(yoe + era * 400 + (m <= 2 ? 1 : 0));
  return {y, m, d};
}
static_assert(days_from_civil(1970, 1, 1) == 0);
static_assert(days_from_civil(2000, 3, 1) == 11017);
static_assert(civil_from_days(11017).year == 2000 && civil_from_days(11017).month == 3);

bool two_digits(std::string_view s, std::size_t at, int& out) noexcept {
  if (at + 2 > s.size()) return false;
  const char a = s[at], b = s[at + 1];
  if (a < '0' || a > '9' || b < '0' || b > '9') return false;
  out = (a - '0') * 10 + (b - '0');
  return true;
}

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool parse_double(std::string_view s, double& out) noexcept {
  if (s.empty()) return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc{} && ptr == s.data() + s.size();
}

// "ddmm.mmmm" (or "dddmm.mmmm") -> degrees; empty -> 0.
bool parse_angle(std::string_view value, std::string_view hemisphere, char negative, double& out) noexcept {
  if (value.empty()) {
    out = 0.0;
    return true;
  }
  double raw = 0.0;
  if (!parse_double(value, raw) || raw < 0.0) return false;
  const double degrees = std::floor(raw / 100.0);
  const double minutes = raw - degrees * 100.0;
  if (minutes >= 60.0) return false;
  out = degrees + minutes / 60.0;
  if (hemisphere.size() == 1 && hemisphere[0] == negative) out = -out;
  return true;
}

}  // namespace

const char* to_string(NmeaStatus s) noexcept {
  switch (s) {
    case NmeaStatus::kOk: return "ok";
    case NmeaStatus::kMissing: return "missing";
    case NmeaStatus::kTruncated: return "truncated";
    case NmeaStatus::kBadChecksum: return "bad checksum";
    case NmeaStatus::kNotRmc: return "not RMC";
    case NmeaStatus::kMalformed: return "malformed";
  }
  return "malformed";
}

std::uint8_t nmea_checksum(std::string_view body) noexcept {
  if (!body.empty() && body.front() == '$') body.remove_prefix(1);
  std::uint8_t sum = 0;
  for (const char c : body) {
    if (c == '*') break;
    sum = static_cast<std::uint8_t>(sum ^ static_cast<std::uint8_t>(c));
  }
  return sum;
}

NmeaStatus parse_rmc(std::string_view s, RmcFix& out) noexcept {
  while (!s.empty() && (s.back() == '\0' || s.back() == '\r' || s.back() == '\n')) s.remove_suffix(1);
  if (s.empty()) return NmeaStatus::kMissing;
  if (s.front() != '$') return NmeaStatus::kMalformed;
  const std::size_t star = s.find('*');
  if (star == std::string_view::npos || star + 3 > s.size()) return NmeaStatus::kTruncated;
  const int hi = hex_value(s[star + 1]), lo = hex_value(s[star + 2]);
  if (hi < 0 || lo < 0 || star + 3 != s.size()) return NmeaStatus::kMalformed;
  if (nmea_checksum(s.substr(0, star)) != hi * 16 + lo) return NmeaStatus::kBadChecksum;

  // Fields between '$' and '*'.
  std::array<std::string_view, 14> f{};
  std::size_t nf = 0;
  std::string_view body = s.substr(1, star - 1);
  while (nf < f.size()) {
    const std::size_t comma = body.find(',');
    f[nf++] = body.substr(0, comma);
    if (comma == std::string_view::npos) break;
    body.remove_prefix(comma + 1);
  }
  if (f[0].size() != 5 || f[0].substr(2) != "RMC") return NmeaStatus::kNotRmc;
  if (nf < 10) return NmeaStatus::kMalformed;

  RmcFix fix;
  const std::string_view time = f[1], date = f[9];
  if (time.size() < 6 || date.size() != 6) return NmeaStatus::kMalformed;
  int ss = 0, yy = 0;
  if (!two_digits(time, 0, fix.hour) || !two_digits(time, 2, fix.minute) || !two_digits(time, 4, ss) ||
      !two_digits(date, 0, fix.day) || !two_digits(date, 2, fix.month) || !two_digits(date, 4, yy)) {
    return NmeaStatus::kMalformed;
  }
  double fraction = 0.0;
  if (time.size() > 6) {
    if (time[6] != '.' || !parse_double(time.substr(6), fraction)) return NmeaStatus::kMalformed;
  }
  if (fix.hour > 23 || fix.minute > 59 || ss > 60 || fix.month < 1 || fix.month > 12 || fix.day < 1 ||
      fix.day > 31) {
    return NmeaStatus::kMalformed;
  }
  if (f[2] == "A") {
    fix.valid = true;
  } else if (f[2] != "V") {
    return NmeaStatus::kMalformed;
  }
  if (!parse_angle(f[3], f[4], 'S', fix.latitude_deg) || !parse_angle(f[5], f[6], 'W', fix.longitude_deg)) {
    return NmeaStatus::kMalformed;
  }
  if (fix.latitude_deg > 90.0 || fix.latitude_deg < -90.0 || fix.longitude_deg > 180.0 || fix.longitude_deg < -180.0)
    return NmeaStatus::kMalformed;
  fix.has_position = !f[3].empty() && (f[4] == "N" || f[4] == "S") && !f[5].empty() && (f[6] == "E" || f[6] == "W");
  if (nf > 12 && f[12].size() == 1) fix.mode = f[12][0];
  fix.year = yy < 80 ? 2000 + yy : 1900 + yy;  // NMEA carries two digits; GPS epochs are >= 1980
  fix.second = ss + fraction;
  const std::int64_t days = days_from_civil(fix.year, fix.month, fix.day);
  fix.hour_start_ns = (days * 86400 + fix.hour * 3600) * kNsPerSec;
  fix.utc_ns = fix.hour_start_ns + (fix.minute * 60 + ss) * kNsPerSec +
               static_cast<Nanos>(std::llround(fraction * 1e9));
  out = fix;
  return NmeaStatus::kOk;
}

PacketStatus parse_position_packet(std::span<const std::byte> bytes, PositionPacket& out) noexcept {
  if (bytes.size() != kPositionPacketSize) return PacketStatus::kWrongSize;
  RawPositionPacket raw;
  std::memcpy(&raw, bytes.data(), sizeof raw);
  PositionPacket p;
  p.sensor_time_us = le32(raw.timestamp);
  p.pps = raw.pps_status <= 3 ? static_cast<PpsState>(raw.pps_status) : PpsState::kError;
  const auto* end = std::find(std::begin(raw.nmea), std::end(raw.nmea), '\0');
  const std::string_view sentence(raw.nmea, static_cast<std::size_t>(end - std::begin(raw.nmea)));
  p.nmea = parse_rmc(sentence, p.fix);
  out = p;
  return PacketStatus::kOk;
}

std::string format_rmc(const RmcInput& in) {
  const Nanos secs = in.utc_ns >= 0 ? in.utc_ns / kNsPerSec : (in.utc_ns - kNsPerSec + 1) / kNsPerSec;
  const std::int64_t days = secs >= 0 ? secs / 86400 : (secs - 86399) / 86400;
  const auto sod = static_cast<int>(secs - days * 86400);
  const Civil c = civil_from_days(days);
  // Whole degrees and minutes rounded to the 4 decimals printed (59.99999' must not print as 60').
  auto split = [](double deg, double& whole, double& minutes) {
    const double total = std::round(std::fabs(deg) * 60.0 * 1e4) / 1e4;
    whole = std::floor(total / 60.0);
    minutes = total - whole * 60.0;
  };
  double lat_deg = 0, lat_min = 0, lon_deg = 0, lon_min = 0;
  split(in.latitude_deg, lat_deg, lat_min);
  split(in.longitude_deg, lon_deg, lon_min);
  std::array<char, 100> body{};
  const int n = std::snprintf(body.data(), body.size(),
                              "GPRMC,%02d%02d%02d,%c,%02d%07.4f,%c,%03d%07.4f,%c,000.0,000.0,%02d%02d%02d,,,A",
                              sod / 3600, (sod / 60) % 60, sod % 60, in.valid ? 'A' : 'V',
                              static_cast<int>(lat_deg), lat_min, in.latitude_deg < 0 ? 'S' : 'N',
                              static_cast<int>(lon_deg), lon_min, in.longitude_deg < 0 ? 'W' : 'E',
                              c.day, c.month, c.year % 100);
  std::string s = "$";
  s.append(body.data(), static_cast<std::size_t>(std::clamp(n, 0, static_cast<int>(body.size()) - 1)));
  std::array<char, 8> tail{};
  std::snprintf(tail.data(), tail.size(), "*%02X\r\n", nmea_checksum(s));
  s += tail.data();
  return s;
}

void encode_position_packet(std::uint32_t sensor_time_us, PpsState pps, std::string_view sentence,
                            std::span<std::byte, kPositionPacketSize> out) noexcept {
  RawPositionPacket raw{};
  put_le32(raw.timestamp, sensor_time_us);
  raw.pps_status = static_cast<std::uint8_t>(pps);
  std::memcpy(raw.nmea, sentence.data(), std::min(sentence.size(), kNmeaFieldSize));
  std::memcpy(out.data(), &raw, sizeof raw);
}

}  // namespace sensor_rig::lidar::velodyne
