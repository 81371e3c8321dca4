#include "sensor_rig/dbw/can/candump.hpp"

#include <charconv>
#include <cstdio>

namespace sensor_rig::dbw::can {
namespace {

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool parse_hex(std::string_view s, std::uint32_t& out) noexcept {
  if (s.empty()) return false;
  std::uint32_t v = 0;
  for (char c : s) {
    const int h = hex_value(c);
    if (h < 0) return false;
    v = (v << 4) | static_cast<std::uint32_t>(h);
  }
  out = v;
  return true;
}

constexpr std::uint32_t kErrFlag = 0x20000000U;

// "sec.frac" -> ns; frac of up to 9 digits.
bool parse_stamp(std::string_view s, Nanos& out) noexcept {
  const auto dot = s.find('.');
  const std::string_view sec = s.substr(0, dot);
  std::int64_t v = 0;
  const auto r = std::from_chars(sec.data(), sec.data() + sec.size(), v);
  if (r.ec != std::errc{} || r.ptr != sec.data() + sec.size() || v < 0 || v > 9'000'000'000LL) return false;
  std::int64_t frac = 0;
  if (dot != std::string_view::npos) {
    const std::string_view f = s.substr(dot + 1);
    if (f.empty() || f.size() > 9) return false;
    for (char c : f) {
      if (c < '0' || c > '9') return false;
      frac = frac * 10 + (c - '0');
    }
    for (std::size_t i = f.size(); i < 9; ++i) frac *= 10;
  }
  out = v * 1'000'000'000LL + frac;
  return true;
}

}  // namespace

bool parse_frame(std::string_view text, Frame& out) {
  out = Frame{};
  const auto hash = text.find('#');
  if (hash == std::string_view::npos) return false;
  std::uint32_t id = 0;
  if (!parse_hex(text.substr(0, hash), id)) return false;
  if (hash == 3) {
    if (id > kStandardIdMask) return false;
    out.id = id;
  } else if (hash == 8) {
    if ((id & kErrFlag) != 0) {
      out.error = true;
      out.id = id & kExtendedIdMask;
    } else if (id > kExtendedIdMask) {
      return false;
    } else {
      out.extended = true;
      out.id = id;
    }
  } else {
    return false;
  }
  std::string_view rest = text.substr(hash + 1);
  std::size_t max_len = kClassicMaxLen;
  if (!rest.empty() && rest[0] == '#') {
    if (rest.size() < 2) return false;
    const int flags = hex_value(rest[1]);
    if (flags < 0) return false;
    out.fd = true;
    out.brs = (flags & 1) != 0;
    out.esi = (flags & 2) != 0;
    rest.remove_prefix(2);
    max_len = kFdMaxLen;
  } else if (!rest.empty() && (rest[0] == 'R' || rest[0] == 'r')) {
    out.rtr = true;
    if (rest.size() == 2 && rest[1] >= '0' && rest[1] <= '8') {
      out.len = static_cast<std::uint8_t>(rest[1] - '0');
    } else if (rest.size() != 1) {
      return false;
    }
    return !out.error;
  }
  std::size_t n = 0;
  std::size_t i = 0;
  while (i < rest.size()) {
    if (rest[i] == '.') {
      ++i;
      continue;
    }
    if (i + 1 >= rest.size() || n >= max_len) return false;
    const int hi = hex_value(rest[i]);
    const int lo = hex_value(rest[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out.data[n++] = static_cast<std::uint8_t>((hi << 4) | lo);
    i += 2;
  }
  if (out.fd && !valid_fd_length(n)) return false;
  out.len = static_cast<std::uint8_t>(n);
  return true;
}

LineStatus parse_candump_line(std::string_view line, LogRecord& out) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n' || line.back() == ' ')) line.remove_suffix(1);
  while (!line.empty() && line.front() == ' ') line.remove_prefix(1);
  if (line.empty()) return LineStatus::kBlank;
  if (line.front() != '(') return LineStatus::kMalformed;
  const auto close = line.find(')');
  if (close == std::string_view::npos) return LineStatus::kMalformed;
  const std::string_view stamp = line.substr(1, close - 1);
  if (!parse_stamp(stamp, out.stamp)) return LineStatus::kMalformed;
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ') return LineStatus::kMalformed;
  rest.remove_prefix(1);
  const auto sp = rest.find(' ');
  if (sp == std::string_view::npos || sp == 0) return LineStatus::kMalformed;
  const std::string_view iface = rest.substr(0, sp);
  std::string_view frame = rest.substr(sp + 1);
  // candump -L may append " T"/" R" (direction) in newer versions: take the first token.
  if (const auto sp2 = frame.find(' '); sp2 != std::string_view::npos) frame = frame.substr(0, sp2);
  if (!parse_frame(frame, out.frame)) return LineStatus::kMalformed;
  out.stamp_text.assign(stamp);
  out.iface.assign(iface);
  return LineStatus::kOk;
}

std::string format_frame(const Frame& f) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  char buf[16];
  std::string out;
  out.reserve(16 + 2 * f.len);
  if (f.error) {
    std::snprintf(buf, sizeof buf, "%08X", (f.id & kExtendedIdMask) | kErrFlag);
  } else if (f.extended) {
    std::snprintf(buf, sizeof buf, "%08X", f.id & kExtendedIdMask);
  } else {
    std::snprintf(buf, sizeof buf, "%03X", f.id & kStandardIdMask);
  }
  out += buf;
  out += '#';
  if (f.rtr) {
    out += 'R';
    if (f.len > 0) out += static_cast<char>('0' + f.len);
    return out;
  }
  if (f.fd) {
    out += '#';
    out += kHex[(f.brs ? 1 : 0) | (f.esi ? 2 : 0)];
  }
  for (std::size_t i = 0; i < f.len; ++i) {
    out += kHex[f.data[i] >> 4];
    out += kHex[f.data[i] & 0xF];
  }
  return out;
}

std::string format_candump_line(Nanos stamp, std::string_view iface, const Frame& f) {
  char buf[48];
  const Nanos s = stamp < 0 ? 0 : stamp;
  std::snprintf(buf, sizeof buf, "(%lld.%06lld) ", static_cast<long long>(s / 1'000'000'000LL),
                static_cast<long long>((s % 1'000'000'000LL) / 1000));
  std::string out(buf);
  out += iface;
  out += ' ';
  out += format_frame(f);
  return out;
}

bool CandumpReader::next(LogRecord& out) {
  while (std::getline(in_, buf_)) {
    ++line_;
    switch (parse_candump_line(buf_, out)) {
      case LineStatus::kOk:
        return true;
      case LineStatus::kBlank:
        break;
      case LineStatus::kMalformed:
        if (malformed_++ == 0) first_bad_line_ = line_;
        break;
    }
  }
  return false;
}

}  // namespace sensor_rig::dbw::can
