#include "sensor_rig/dbw/bridge/protocol.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dbw/dbc/codec.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace sensor_rig::dbw {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The roles a message of each direction may map. Any number of messages, each named freely; a role
// may appear in several messages (e.g. one enable bit per actuator message).
struct GroupSpec {
  std::vector<std::string_view> roles;
  std::vector<std::string_view> required;      // mapped by at least one message of the group
  std::vector<std::string_view> needs_enable;  // a message mapping one of these must map "enable" too
};
const GroupSpec kTxSpec = {{"enable", "mode", "angle", "torque", "gear", "throttle", "brake", "accel", "state"},
                           {"enable", "angle", "throttle", "brake"},
                           {"mode", "angle", "torque", "gear", "throttle", "brake", "accel"}};
const GroupSpec kRxSpec = {{"ready", "engaged", "override", "fault", "fault_code", "speed", "steering_angle", "yaw_rate",
                            "gear", "fl", "fr", "rl", "rr"},
                           {"ready", "override", "fault", "speed", "steering_angle"},
                           {}};

bool contains(const std::vector<std::string_view>& v, std::string_view x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// A 4-bit counter must be one nibble; a CRC one whole byte (either byte order).
bool nibble_of(const dbc::Signal& s, std::size_t& byte, bool& high) {
  if (s.length != 4) return false;
  const int in_byte = s.start_bit % 8;
  byte = s.start_bit / 8U;
  if (s.order == dbc::ByteOrder::kIntel && (in_byte == 0 || in_byte == 4)) {
    high = in_byte == 4;
    return true;
  }
  if (s.order == dbc::ByteOrder::kMotorola && (in_byte == 3 || in_byte == 7)) {
    high = in_byte == 7;
    return true;
  }
  return false;
}
bool byte_of(const dbc::Signal& s, std::size_t& byte) {
  if (s.length != 8) return false;
  byte = s.start_bit / 8U;
  return (s.order == dbc::ByteOrder::kIntel && s.start_bit % 8 == 0) ||
         (s.order == dbc::ByteOrder::kMotorola && s.start_bit % 8 == 7);
}

// signals: {role: SIGNAL} or {role: {signal: SIGNAL, scale: X}} (bus value = role value * scale).
void bind_signals(const config::Node& n, const GroupSpec& spec, RoleMessage& rm) {
  const auto sigs = n.child("signals", true);
  if (!sigs) return;
  for (const auto& kv : sigs->yaml()) {
    const std::string role = kv.first.Scalar();
    if (!contains(spec.roles, role)) {
      sigs->fail(role, "unknown role '" + role + "'");
      continue;
    }
    std::string name;
    double scale = 1.0;
    if (kv.second.IsMap()) {
      const auto b = sigs->child(role);
      b->allow_keys({"signal", "scale"});
      name = b->get_string("signal");
      scale = b->get_double("scale", -1e9, 1e9, 1.0);
      if (scale == 0.0) b->fail("scale", "must not be 0");
    } else {
      name = sigs->get_string(role);
    }
    const dbc::Signal* s = rm.message->find(name);
    if (s == nullptr) {
      sigs->fail(role, "no signal '" + name + "' in message " + rm.message->name);
      continue;
    }
    rm.signals.emplace(role, s);
    if (scale != 1.0) rm.scales.emplace(role, scale);
  }
  const bool actuates = std::any_of(spec.needs_enable.begin(), spec.needs_enable.end(),
                                    [&rm](std::string_view r) { return rm.signal(r) != nullptr; });
  if (actuates && rm.signal("enable") == nullptr) sigs->fail("enable", "required role 'enable' is not mapped");
}

// const: {SIGNAL: value} written into every frame of the message (e.g. a request-type multiplexor).
void bind_constants(const config::Node& n, RoleMessage& rm) {
  const auto c = n.child("const");
  if (!c) return;
  for (const auto& kv : c->yaml()) {
    const std::string name = kv.first.Scalar();
    const dbc::Signal* s = rm.message->find(name);
    if (s == nullptr) {
      c->fail(name, "no signal '" + name + "' in message " + rm.message->name);
      continue;
    }
    rm.constants.emplace_back(s, c->get_double(name, -1e12, 1e12));
  }
}

// Counter/CRC signals and the message's own E2E settings (`e2e:` overrides the file's defaults;
// `data_id_list:` gives P02's 16 Data IDs, default data_id + counter).
void bind_e2e(const config::Node& n, const safety::E2eConfig& base, RoleMessage& rm) {
  const std::string& msg = rm.message->name;
  rm.e2e = base;
  if (const auto e = n.child("e2e")) {
    e->allow_keys({"profile", "data_id_mode", "max_delta"});
    const std::string prof = e->get_choice("profile", {"none", "counter", "j1850", "p01", "p02"}, std::string(safety::to_string(base.profile)));
    (void)safety::parse_profile(prof, rm.e2e.profile);
    if (e->has("data_id_mode")) {
      (void)safety::parse_id_mode(e->get_choice("data_id_mode", {"both", "alt", "low", "nibble"}), rm.e2e.id_mode);
    }
    rm.e2e.max_delta = static_cast<std::uint8_t>(e->get_int("max_delta", 1, 14, base.max_delta));
  }
  const bool has_counter = n.has("counter");
  const bool has_crc = n.has("crc");
  if ((!has_counter && !has_crc) || rm.e2e.profile == safety::E2eProfile::kNone) {
    rm.e2e.profile = safety::E2eProfile::kNone;
    return;
  }
  if (has_counter) {
    const std::string cname = n.get_string("counter");
    const dbc::Signal* c = rm.message->find(cname);
    if (c == nullptr || !nibble_of(*c, rm.e2e.counter_byte, rm.e2e.counter_high_nibble)) {
      n.fail("counter", "'" + cname + "' must be a 4-bit, nibble-aligned signal of " + msg);
    }
  } else {
    n.fail("counter", "E2E needs a counter signal when a CRC is mapped");
  }
  if (has_crc) {
    const std::string cname = n.get_string("crc");
    const dbc::Signal* c = rm.message->find(cname);
    if (c == nullptr || !byte_of(*c, rm.e2e.crc_byte)) {
      n.fail("crc", "'" + cname + "' must be an 8-bit, byte-aligned signal of " + msg);
    }
  } else if (safety::has_crc(rm.e2e.profile)) {
    rm.e2e.profile = safety::E2eProfile::kCounter;
  }
  rm.e2e.data_id = static_cast<std::uint16_t>(n.get_int("data_id", 0, 0xFFFF, 0));
  for (std::size_t i = 0; i < 16; ++i) rm.e2e.data_id_list[i] = static_cast<std::uint8_t>((rm.e2e.data_id + i) & 0xFF);
  if (n.has("data_id_list")) {
    const YAML::Node list = n.yaml()["data_id_list"];
    if (!list.IsSequence() || list.size() != 16) {
      n.fail("data_id_list", "must be a list of 16 bytes (P02: one Data ID per counter value)");
      return;
    }
    for (std::size_t i = 0; i < 16; ++i) {
      try {
        const int v = list[i].as<int>();
        if (v < 0 || v > 255) throw YAML::Exception(YAML::Mark::null_mark(), "range");
        rm.e2e.data_id_list[i] = static_cast<std::uint8_t>(v);
      } catch (const YAML::Exception&) {
        n.fail("data_id_list", "entry " + std::to_string(i) + " is not a byte 0..255");
      }
    }
  }
}

}  // namespace

const dbc::Signal* RoleMessage::signal(std::string_view name) const noexcept {
  const auto it = signals.find(name);
  return it == signals.end() ? nullptr : it->second;
}

bool RoleMessage::matches(const can::Frame& f) const noexcept {
  return message != nullptr && !f.error && !f.rtr && f.id == message->id && f.extended == message->extended;
}

std::string fnv1a64_hex(std::string_view a, std::string_view b) {
  std::uint64_t h = 1469598103934665603ULL;
  auto mix = [&h](std::string_view s) {
    for (unsigned char c : s) {
      h ^= c;
      h *= 1099511628211ULL;
    }
  };
  mix(a);
  mix(std::string_view("\0", 1));
  mix(b);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

Protocol Protocol::load(const std::string& yaml_path) {
  auto problems = std::make_shared<config::Problems>();
  const config::Node root = config::Node::load_file(yaml_path, problems);
  problems->throw_if_any();
  Protocol p;
  p.mapping_path_ = yaml_path;
  root.allow_keys({"dbc", "vehicle", "limits", "timing", "e2e", "tx", "rx"});
  const std::string dbc_path = root.get_path("dbc");
  std::string dbc_text;
  try {
    dbc_text = read_all(dbc_path);
    if (dbc_text.empty()) throw dbc::DbcError(dbc_path, 0, "cannot open DBC file (or empty)");
    p.db_ = std::make_shared<const dbc::Database>(dbc::parse(dbc_text, dbc_path));
  } catch (const dbc::DbcError& e) {
    root.fail("dbc", e.what());
    problems->throw_if_any();
  }
  const std::string vehicle = root.get_string("vehicle", std::string("paravan_ref"));
  if (const auto* table = safety::find_vehicle(vehicle)) {
    p.limits_ = *table;
  } else {
    root.fail("vehicle", "unknown vehicle limit table '" + vehicle + "' (paravan_ref, eclass_track)");
  }
  // Optional per-axis overrides: limits: {steering_angle: {min: .., max: .., rate: .., action: clamp|reject}}
  if (const auto lim = root.child("limits")) {
    lim->allow_keys({"steering_angle", "steering_torque", "throttle", "brake", "accel"});
    for (std::size_t i = 0; i < safety::kAxes; ++i) {
      const auto axis = static_cast<safety::Axis>(i);
      const auto a = lim->child(safety::to_string(axis));
      if (!a) continue;
      a->allow_keys({"min", "max", "rate", "action"});
      safety::AxisLimit& l = p.limits_[axis];
      l.min = a->get_double("min", -1e6, 1e6, l.min);
      l.max = a->get_double("max", -1e6, 1e6, l.max);
      l.max_rate = a->get_double("rate", 0.0, 1e6, l.max_rate);
      l.action = a->get_choice("action", {"clamp", "reject"}, std::string(l.action == safety::LimitAction::kClamp ? "clamp" : "reject")) ==
                         "reject"
                     ? safety::LimitAction::kReject
                     : safety::LimitAction::kClamp;
      if (!(l.min < l.max)) a->fail("max", "must be greater than min");
    }
  }
  if (const auto t = root.child("timing")) {
    t->allow_keys({"command_timeout_ms", "ecu_timeout_ms", "tx_period_ms"});
    p.timing_.command_timeout_ns = t->get_int("command_timeout_ms", 5, 2000, 100) * 1'000'000;
    p.timing_.ecu_timeout_ns = t->get_int("ecu_timeout_ms", 5, 2000, 100) * 1'000'000;
    p.timing_.tx_period_ns = t->get_int("tx_period_ms", 1, 1000, 10) * 1'000'000;
    if (p.timing_.tx_period_ns >= p.timing_.command_timeout_ns) {
      t->fail("tx_period_ms", "must be shorter than command_timeout_ms");
    }
  }
  safety::E2eConfig e2e_base;
  if (const auto e = root.child("e2e")) {
    e->allow_keys({"profile", "data_id_mode", "max_delta", "tolerance"});
    const std::string prof = e->get_choice("profile", {"none", "counter", "j1850", "p01", "p02"}, std::string("p01"));
    (void)safety::parse_profile(prof, e2e_base.profile);
    const std::string mode = e->get_choice("data_id_mode", {"both", "alt", "low", "nibble"}, std::string("both"));
    (void)safety::parse_id_mode(mode, e2e_base.id_mode);
    e2e_base.max_delta = static_cast<std::uint8_t>(e->get_int("max_delta", 1, 14, 1));
    p.e2e_tolerance_ = static_cast<int>(e->get_int("tolerance", 0, 100, 3));
  }
  auto load_group = [&](std::string_view group, const GroupSpec& spec, std::vector<RoleMessage>& out) {
    const auto g = root.child(group, true);
    if (!g) return;
    for (const auto& kv : g->yaml()) {
      const std::string label = kv.first.Scalar();
      const auto n = g->child(label, true);
      if (!n) continue;
      n->allow_keys({"message", "data_id", "data_id_list", "e2e", "counter", "crc", "signals", "const"});
      RoleMessage rm;
      rm.role = label;
      const std::string msg = n->get_string("message");
      rm.message = p.db_->find(msg);
      if (rm.message == nullptr) {
        n->fail("message", "no message '" + msg + "' in " + dbc_path);  // NOLINT(performance-inefficient-string-concatenation): a config error, once
        continue;
      }
      bind_signals(*n, spec, rm);
      bind_constants(*n, rm);
      bind_e2e(*n, e2e_base, rm);
      out.push_back(std::move(rm));
    }
    for (auto r : spec.required) {
      const bool mapped = std::any_of(out.begin(), out.end(), [r](const RoleMessage& m) { return m.signal(r) != nullptr; });
      if (!mapped) g->fail(r, "required role '" + std::string(r) + "' is not mapped in any " + std::string(group) + " message");
    }
  };
  load_group("tx", kTxSpec, p.tx_);
  load_group("rx", kRxSpec, p.rx_);
  problems->throw_if_any();
  p.hash_ = fnv1a64_hex(dbc_text, read_all(yaml_path));
  return p;
}

const RoleMessage* Protocol::tx(std::string_view role) const noexcept {
  for (const auto& m : tx_) {
    if (m.role == role) return &m;
  }
  return nullptr;
}

const RoleMessage* Protocol::rx(std::string_view role) const noexcept {
  for (const auto& m : rx_) {
    if (m.role == role) return &m;
  }
  return nullptr;
}

bool Protocol::start_frame(const RoleMessage& rm, can::Frame& out) noexcept {
  out = can::Frame{};
  out.id = rm.message->id;
  out.extended = rm.message->extended;
  out.len = rm.message->size;
  out.fd = rm.message->size > can::kClassicMaxLen;
  for (const auto& [sig, v] : rm.constants) {
    if (dbc::encode(*sig, v, out.payload()) == dbc::EncodeStatus::kOutOfFrame) return false;
  }
  return true;
}

bool Protocol::encode(const RoleMessage& rm, std::initializer_list<std::pair<std::string_view, double>> values,
                      safety::E2eSender* e2e, can::Frame& out, int* clamped) const noexcept {
  if (!start_frame(rm, out)) return false;
  for (const auto& [role, v] : values) {
    const dbc::Signal* s = rm.signal(role);
    if (s == nullptr) continue;
    const auto st = dbc::encode(*s, v * rm.scale(role), out.payload());
    if (st == dbc::EncodeStatus::kNotFinite || st == dbc::EncodeStatus::kOutOfFrame) return false;
    if (st == dbc::EncodeStatus::kClamped && clamped != nullptr) ++*clamped;
  }
  if (e2e != nullptr && rm.e2e.profile != safety::E2eProfile::kNone) return e2e->protect(out.payload());
  return true;
}

std::optional<double> Protocol::value(const RoleMessage& rm, std::string_view role, const can::Frame& f) noexcept {
  const dbc::Signal* s = rm.signal(role);
  if (s == nullptr) return std::nullopt;
  const auto v = dbc::decode(*s, f.payload());
  if (!v) return std::nullopt;
  return *v / rm.scale(role);
}

}  // namespace sensor_rig::dbw
