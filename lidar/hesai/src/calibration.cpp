// Hesai angle-correction and firing-time CSV parsing, built-in tables, validation.
#include "sensor_rig/lidar/hesai/calibration.hpp"

#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace sensor_rig::lidar::hesai {
namespace {

// Pandar40P user manual: nominal elevation per channel; azimuth offsets repeat 3.125 / -5.208 /
// -1.042 from channel 7 to 30, every other channel is at -1.042.
constexpr double k40PElevation[40] = {15,    11,    8,     5,     3,     2,     1.67,  1.33,  1,     0.67,
                                      0.33,  0,     -0.33, -0.67, -1,    -1.33, -1.66, -2,    -2.33, -2.67,
                                      -3,    -3.33, -3.67, -4,    -4.33, -4.67, -5,    -5.33, -5.67, -6,
                                      -7,    -8,    -9,    -10,   -11,   -12,   -13,   -14,   -19,   -25};
double azimuth_40p(int channel) {  // 1-based
  if (channel < 7 || channel > 30) return -1.042;
  constexpr double kCycle[3] = {3.125, -5.208, -1.042};
  return kCycle[(channel - 7) % 3];
}

[[noreturn]] void fail(const std::string& source, int line, const std::string& what) {
  throw DecoderConfigError(source + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + what);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::optional<double> number(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || s.empty() || !std::isfinite(v)) return std::nullopt;
  return v;
}

struct Row {
  int line;
  std::vector<std::string_view> fields;
};

// Splits into rows of comma-separated fields; drops a UTF-8 BOM, blank lines and a header line
// (a first row whose first field is not a number).
std::vector<Row> rows(std::string_view text) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  std::vector<Row> out;
  int line = 0;
  bool first = true;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    std::string_view l = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
    ++line;
    if (trim(l).empty()) continue;
    Row r{line, {}};
    for (std::size_t pos = 0;;) {
      const auto c = l.find(',', pos);
      r.fields.push_back(trim(l.substr(pos, c == std::string_view::npos ? std::string_view::npos : c - pos)));
      if (c == std::string_view::npos) break;
      pos = c + 1;
    }
    const bool header = first && !number(r.fields[0]);
    first = false;
    if (!header) out.push_back(std::move(r));
  }
  return out;
}

// Channel number of a row, 1..channels, each once.
int channel_of(const Row& r, const std::string& source, const ModelInfo& mi, std::vector<bool>& seen) {
  const auto v = number(r.fields[0]);
  if (!v || *v != std::floor(*v)) fail(source, r.line, "channel '" + std::string(r.fields[0]) + "' is not an integer");
  if (*v < 1 || *v > mi.channels) {
    fail(source, r.line,
         "channel " + std::string(r.fields[0]) + " is out of range 1.." + std::to_string(mi.channels) + " (" +
             std::string(mi.name) + ")");
  }
  const int c = static_cast<int>(*v);
  if (seen[static_cast<std::size_t>(c - 1)]) fail(source, r.line, "channel " + std::to_string(c) + " appears twice");
  seen[static_cast<std::size_t>(c - 1)] = true;
  return c;
}

double field(const Row& r, std::size_t i, const char* name, const std::string& source) {
  const auto v = number(r.fields[i]);
  if (!v) fail(source, r.line, std::string(name) + " '" + std::string(r.fields[i]) + "' is not a number");
  return *v;
}

void check_complete(const std::vector<bool>& seen, const std::string& source, const ModelInfo& mi) {
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) {
      fail(source, 0, "channel " + std::to_string(i + 1) + " is missing (" + std::string(mi.name) + " has " +
                          std::to_string(mi.channels) + " channels)");
    }
  }
}

}  // namespace

Calibration default_calibration(Model m) {
  const ModelInfo& mi = model_info(m);
  Calibration c;
  c.source = "built-in " + std::string(mi.name);
  c.channels.resize(static_cast<std::size_t>(mi.channels));
  for (int i = 0; i < mi.channels; ++i) {
    auto& a = c.channels[static_cast<std::size_t>(i)];
    if (m == Model::kPandar40P) {
      a.elevation_deg = k40PElevation[i];
      a.azimuth_deg = azimuth_40p(i + 1);
    } else {
      a.elevation_deg = 15.0 - i;
    }
  }
  return c;
}

FiringTimes default_firing_times(Model m) {
  const ModelInfo& mi = model_info(m);
  return FiringTimes{{mi.firing_us.begin(), mi.firing_us.end()}, "built-in " + std::string(mi.name)};
}

Calibration parse_angle_csv(std::string_view text, const std::string& source, Model m) {
  const ModelInfo& mi = model_info(m);
  Calibration c;
  c.source = source;
  c.channels.resize(static_cast<std::size_t>(mi.channels));
  std::vector<bool> seen(c.channels.size(), false);
  for (const auto& r : rows(text)) {
    if (r.fields.size() != 3) {
      fail(source, r.line,
           "expected 3 fields (channel,elevation,azimuth), found " + std::to_string(r.fields.size()));
    }
    const int ch = channel_of(r, source, mi, seen);
    auto& a = c.channels[static_cast<std::size_t>(ch - 1)];
    a.elevation_deg = field(r, 1, "elevation", source);
    a.azimuth_deg = field(r, 2, "azimuth", source);
    if (std::abs(a.elevation_deg) > 90.0) fail(source, r.line, "elevation is beyond ±90°");
    if (std::abs(a.azimuth_deg) > 45.0) fail(source, r.line, "azimuth offset is beyond ±45°");
  }
  check_complete(seen, source, mi);
  return c;
}

FiringTimes parse_firetime_csv(std::string_view text, const std::string& source, Model m) {
  const ModelInfo& mi = model_info(m);
  FiringTimes f;
  f.source = source;
  f.us.resize(static_cast<std::size_t>(mi.channels));
  std::vector<bool> seen(f.us.size(), false);
  for (const auto& r : rows(text)) {
    if (r.fields.size() != 2) {
      fail(source, r.line, "expected 2 fields (channel,fire time), found " + std::to_string(r.fields.size()));
    }
    const int ch = channel_of(r, source, mi, seen);
    const double us = field(r, 1, "fire time", source);
    // A channel fires within about one azimuth group (XT32 overlaps the next group slightly).
    if (std::abs(us) * 1000.0 > 2.0 * mi.group_period_ns) {
      fail(source, r.line, "fire time " + std::string(r.fields[1]) + " µs is beyond two firing groups (" +
                               std::to_string(2 * mi.group_period_ns / 1000) + " µs)");
    }
    f.us[static_cast<std::size_t>(ch - 1)] = us;
  }
  check_complete(seen, source, mi);
  return f;
}

bool is_firetime_csv(std::string_view text) noexcept {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  const auto header = text.substr(0, text.find('\n'));
  std::string lower;
  for (char ch : header) lower += static_cast<char>(ch >= 'A' && ch <= 'Z' ? ch - 'A' + 'a' : ch);
  return lower.find("fire") != std::string::npos;
}

}  // namespace sensor_rig::lidar::hesai
