// Ouster metadata JSON -> SensorMetadata, flat (FW <= 2.3) and nested (FW 2.4+) formats.
// Every error names the file and the key path, e.g. "meta.json: key 'data_format.columns_per_frame': ...".
#include "sensor_rig/lidar/ouster/metadata.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

namespace sensor_rig::lidar::ouster {
namespace {

using Json = nlohmann::json;

// A JSON value with its key path, for messages.
class Node {
 public:
  Node(const Json& j, std::string path, const std::string& source) : j_(&j), path_(std::move(path)), src_(&source) {}

  [[noreturn]] void fail(const std::string& what) const {
    if (path_.empty()) throw MetadataError(*src_ + ": " + what);
    throw MetadataError(*src_ + ": key '" + path_ + "': " + what);
  }
  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  [[nodiscard]] const Json& raw() const noexcept { return *j_; }

  [[nodiscard]] std::optional<Node> get(const std::string& key) const {
    if (!j_->is_object()) return std::nullopt;
    const auto it = j_->find(key);
    if (it == j_->end() || it->is_null()) return std::nullopt;
    return Node(*it, path_.empty() ? key : path_ + "." + key, *src_);
  }
  [[nodiscard]] Node req(const std::string& key) const {
    if (auto n = get(key)) return *n;
    throw MetadataError(*src_ + ": key '" + (path_.empty() ? key : path_ + "." + key) + "' is missing");
  }
  [[nodiscard]] bool is_object() const noexcept { return j_->is_object(); }

  [[nodiscard]] double number() const {
    if (!j_->is_number()) fail("expected a number, got " + j_->dump());
    const double v = j_->get<double>();
    if (!std::isfinite(v)) fail("not a finite number");
    return v;
  }
  [[nodiscard]] long long integer(long long lo, long long hi) const {
    if (!j_->is_number_integer() && !j_->is_number_unsigned()) fail("expected an integer, got " + j_->dump());
    const auto v = j_->get<long long>();
    if (v < lo || v > hi) fail(std::to_string(v) + " is not in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  [[nodiscard]] std::string text() const {
    if (j_->is_string()) return j_->get<std::string>();
    if (j_->is_number()) return j_->dump();
    fail("expected a string, got " + j_->dump());
  }
  [[nodiscard]] std::vector<double> numbers(std::size_t n, double lo, double hi) const {
    if (!j_->is_array()) fail("expected an array of " + std::to_string(n) + " numbers");
    if (j_->size() != n)
      fail("expected " + std::to_string(n) + " numbers, got " + std::to_string(j_->size()));
    std::vector<double> out;
    out.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Node e((*j_)[i], path_ + "[" + std::to_string(i) + "]", *src_);
      const double v = e.number();
      if (v < lo || v > hi) e.fail(std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
      out.push_back(v);
    }
    return out;
  }
  [[nodiscard]] Mat4 matrix() const {
    const auto v = numbers(16, -1e6, 1e6);
    Mat4 m{};
    for (std::size_t i = 0; i < 16; ++i) m[i] = v[i];
    if (m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0)
      fail("not a homogeneous transform (last row must be 0 0 0 1)");
    return m;
  }

 private:
  const Json* j_;
  std::string path_;
  const std::string* src_;
};

struct Mode {
  int columns = 0;
  double fps = 0.0;
};

// "1024x10" -> 1024 columns at 10 Hz.
Mode parse_mode(const Node& n) {
  const std::string s = n.text();
  const auto x = s.find('x');
  Mode m;
  try {
    std::size_t used = 0;
    if (x == std::string::npos || x == 0) throw std::invalid_argument(s);
    m.columns = std::stoi(s.substr(0, x), &used);
    if (used != x) throw std::invalid_argument(s);
    m.fps = std::stod(s.substr(x + 1), &used);
    if (used != s.size() - x - 1) throw std::invalid_argument(s);
  } catch (const std::exception&) {
    n.fail("expected COLUMNSxFPS such as 1024x10, got '" + s + "'");
  }
  if (m.columns < 1 || m.columns > 32768 || !(m.fps > 0.0 && m.fps <= 100.0))
    n.fail("'" + s + "' is not a plausible lidar mode");
  return m;
}

std::optional<Node> first_of(std::initializer_list<std::optional<Node>> nodes) {
  for (const auto& n : nodes)
    if (n) return n;
  return std::nullopt;
}

void read_data_format(const Node& df, const std::optional<Node>& profile_node, SensorMetadata& m) {
  m.pixels_per_column = static_cast<int>(df.req("pixels_per_column").integer(1, 1024));
  m.columns_per_frame = static_cast<int>(df.req("columns_per_frame").integer(1, 32768));
  m.columns_per_packet = static_cast<int>(df.req("columns_per_packet").integer(1, m.columns_per_frame));
  if (profile_node) {
    const std::string name = profile_node->text();
    const auto p = profile_from_name(name);
    if (!p) profile_node->fail("unsupported UDP profile '" + name + "' (supported: " + profile_names() + ")");
    m.profile = *p;
  }
  m.header_type = default_header_type(m.profile);
  if (auto h = df.get("header_type")) {
    const std::string t = h->text();
    if (t == "FUSA" && m.profile != Profile::kLegacy) {
      m.header_type = HeaderType::kFusa;
    } else if (t != "STANDARD" && t != "FUSA") {
      h->fail("expected STANDARD or FUSA, got '" + t + "'");
    }
  }
  try {
    (void)m.layout();
  } catch (const std::invalid_argument& e) {
    df.fail(e.what());
  }
  if (auto w = df.get("column_window")) {
    const auto v = w->numbers(2, 0, m.columns_per_frame - 1);
    if (v[0] != std::floor(v[0]) || v[1] != std::floor(v[1])) w->fail("expected two column indices");
    m.column_window_first = static_cast<int>(v[0]);
    m.column_window_last = static_cast<int>(v[1]);
  } else {
    m.column_window_first = 0;
    m.column_window_last = m.columns_per_frame - 1;
  }
  if (auto s = df.get("pixel_shift_by_row")) {
    const double lim = m.columns_per_frame;
    for (const double v : s->numbers(static_cast<std::size_t>(m.pixels_per_column), -lim, lim))
      m.pixel_shift_by_row.push_back(static_cast<int>(v));
  } else {
    m.pixel_shift_by_row.assign(static_cast<std::size_t>(m.pixels_per_column), 0);
  }
}

void read_angles(const Node& parent, SensorMetadata& m) {
  const auto n = static_cast<std::size_t>(m.pixels_per_column);
  m.beam_altitude_deg = parent.req("beam_altitude_angles").numbers(n, -90.0, 90.0);
  m.beam_azimuth_deg = parent.req("beam_azimuth_angles").numbers(n, -180.0, 180.0);
  if (auto t = parent.get("beam_to_lidar_transform")) {
    m.beam_to_lidar = t->matrix();
  } else if (auto d = parent.get("lidar_origin_to_beam_origin_mm")) {
    m.beam_to_lidar = kIdentity;
    m.beam_to_lidar[3] = d->number();
  } else {
    parent.fail("needs beam_to_lidar_transform or lidar_origin_to_beam_origin_mm");
  }
}

void read_info(const Node& info, SensorMetadata& m) {
  if (auto v = info.get("prod_line")) m.prod_line = v->text();
  if (auto v = info.get("prod_sn")) m.prod_sn = v->text();
  if (auto v = info.get("build_rev")) m.fw_rev = v->text();
  if (auto v = info.get("initialization_id")) m.init_id = static_cast<std::uint32_t>(v->integer(0, 0xFFFFFF));
}

void read_ports(const Node& n, SensorMetadata& m) {
  if (auto v = n.get("udp_port_lidar")) m.udp_port_lidar = static_cast<std::uint16_t>(v->integer(0, 65535));
  if (auto v = n.get("udp_port_imu")) m.udp_port_imu = static_cast<std::uint16_t>(v->integer(0, 65535));
}

void apply_mode(const Node& mode_node, SensorMetadata& m) {
  const Mode mode = parse_mode(mode_node);
  m.lidar_mode = mode_node.text();
  m.frames_per_second = mode.fps;
  if (mode.columns != m.columns_per_frame)
    mode_node.fail("'" + m.lidar_mode + "' does not match columns_per_frame " + std::to_string(m.columns_per_frame));
}

void parse_nested(const Node& root, SensorMetadata& m) {
  const Node df = root.req("lidar_data_format");
  const auto cfg = root.get("config_params");
  const auto profile = first_of({df.get("udp_profile_lidar"), cfg ? cfg->get("udp_profile_lidar") : std::nullopt});
  read_data_format(df, profile, m);
  read_angles(root.req("beam_intrinsics"), m);
  m.lidar_to_sensor = root.req("lidar_intrinsics").req("lidar_to_sensor_transform").matrix();
  if (auto info = root.get("sensor_info")) read_info(*info, m);
  if (cfg) {
    read_ports(*cfg, m);
    if (auto o = cfg->get("return_order")) {
      const std::string s = o->text();
      if (s == "STRONGEST_TO_WEAKEST" || s == "STRONGEST_RETURN_FIRST") {
        m.return_order = ReturnOrder::kStrongestFirst;
      } else if (s == "FARTHEST_TO_NEAREST" || s == "LAST_RETURN_FIRST") {
        m.return_order = ReturnOrder::kFarthestFirst;
      } else if (s == "NEAREST_TO_FARTHEST") {
        m.return_order = ReturnOrder::kNearestFirst;
      } else {
        o->fail("unknown return order '" + s + "'");
      }
    }
  }
  if (auto mode = cfg ? cfg->get("lidar_mode") : std::nullopt) {
    apply_mode(*mode, m);
  } else if (auto fps = df.get("fps")) {
    m.frames_per_second = static_cast<double>(fps->integer(1, 100));
    m.lidar_mode = std::to_string(m.columns_per_frame) + "x" + std::to_string(fps->integer(1, 100));
  } else {
    root.fail("needs config_params.lidar_mode (or lidar_data_format.fps)");
  }
}

void parse_flat(const Node& root, SensorMetadata& m) {
  const Node mode_node = root.req("lidar_mode");
  const Mode mode = parse_mode(mode_node);
  if (auto df = root.get("data_format")) {
    if (!df->is_object()) df->fail("expected an object");
    read_data_format(*df, first_of({df->get("udp_profile_lidar"), root.get("udp_profile_lidar")}), m);
  } else {
    // FW 1.x: no data_format; the packet layout is the legacy one with one pixel per beam.
    const Node alt = root.req("beam_altitude_angles");
    if (!alt.raw().is_array() || alt.raw().empty() || alt.raw().size() > 1024) alt.fail("expected an array of beam angles");
    m.pixels_per_column = static_cast<int>(alt.raw().size());
    m.columns_per_frame = mode.columns;
    m.columns_per_packet = 16;
    m.column_window_first = 0;
    m.column_window_last = mode.columns - 1;
    m.pixel_shift_by_row.assign(static_cast<std::size_t>(m.pixels_per_column), 0);
    m.profile = Profile::kLegacy;
    m.header_type = HeaderType::kLegacy;
    try {
      (void)m.layout();
    } catch (const std::invalid_argument& e) {
      alt.fail(e.what());
    }
  }
  apply_mode(mode_node, m);
  read_angles(root, m);
  m.lidar_to_sensor = root.req("lidar_to_sensor_transform").matrix();
  read_info(root, m);
  read_ports(root, m);
}

}  // namespace

SensorMetadata parse_metadata(std::string_view json_text, const std::string& source) {
  Json doc;
  try {
    doc = Json::parse(json_text);
  } catch (const Json::exception& e) {  // parse_error, and out_of_range for numbers too large
    throw MetadataError(source + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object()) throw MetadataError(source + ": expected a JSON object at the top level");
  SensorMetadata m;
  m.source = source;
  const Node root(doc, "", source);
  m.nested_format = doc.contains("lidar_data_format") || doc.contains("beam_intrinsics");
  try {
    if (m.nested_format) {
      parse_nested(root, m);
    } else {
      parse_flat(root, m);
    }
  } catch (const Json::exception& e) {  // not expected: every read checks the type first
    throw MetadataError(source + ": " + e.what());
  }
  return m;
}

}  // namespace sensor_rig::lidar::ouster
