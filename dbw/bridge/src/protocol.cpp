#include "sensor_rig/dbw/bridge/protocol.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "sensor_rig/config/node.hpp"
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

struct RoleSpec {
  std::string_view role;
  std::vector<std::string_view> required;
  std::vector<std::string_view> optional;
  bool message_required;
};

const std::vector<RoleSpec> kTxSpecs = {
    {"steering", {"enable", "angle"}, {"torque", "mode"}, true},
    {"longitudinal", {"enable", "throttle", "brake"}, {"gear", "accel"}, true},
    {"heartbeat", {}, {"state"}, false},
};
const std::vector<RoleSpec> kRxSpecs = {
    {"status", {"ready", "override", "fault"}, {"engaged", "fault_code"}, true},
    {"feedback", {"speed", "steering_angle"}, {"yaw_rate", "gear"}, true},
    {"wheels", {"fl", "fr", "rl", "rr"}, {}, false},
};

// A 4-bit counter must be one nibble; a CRC one whole byte (either byte order).
bool nibble_of(const dbc::Signal& s, std::size_t& byte, bool& high) {
  if (s.length != 4) return false;
  const int in_byte = s.start_bit % 8;
  byte = s.start_bit / 8U;
  if (s.order == dbc::ByteOrder::intel && (in_byte == 0 || in_byte == 4)) {
    high = in_byte == 4;
    return true;
  }
  if (s.order == dbc::ByteOrder::motorola && (in_byte == 3 || in_byte == 7)) {
    high = in_byte == 7;
    return true;
  }
  return false;
}
bool byte_of(const dbc::Signal& s, std::size_t& byte) {
  if (s.length != 8) return false;
  byte = s.start_bit / 8U;
  return (s.order == dbc::ByteOrder::intel && s.start_bit % 8 == 0) ||
         (s.order == dbc::ByteOrder::motorola && s.start_bit % 8 == 7);
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
      l.action = a->get_choice("action", {"clamp", "reject"}, std::string(l.action == safety::LimitAction::clamp ? "clamp" : "reject")) ==
                         "reject"
                     ? safety::LimitAction::reject
                     : safety::LimitAction::clamp;
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
  auto load_group = [&](std::string_view group, const std::vector<RoleSpec>& specs, std::vector<RoleMessage>& out) {
    const auto g = root.child(group, true);
    if (!g) return;
    std::vector<std::string_view> names;
    for (const auto& s : specs) names.push_back(s.role);
    for (const auto& kv : g->yaml()) {
      bool known = false;
      for (auto n : names) known = known || n == kv.first.Scalar();
      if (!known) g->fail(kv.first.Scalar(), "unknown role (allowed: " + std::string(specs[0].role) + ", ...)");
    }
    for (const auto& spec : specs) {
      const auto n = g->child(spec.role, spec.message_required);
      if (!n) continue;
      n->allow_keys({"message", "data_id", "counter", "crc", "signals"});
      RoleMessage rm;
      rm.role = std::string(spec.role);
      const std::string msg = n->get_string("message");
      rm.message = p.db_->find(msg);
      if (rm.message == nullptr) {
        n->fail("message", "no message '" + msg + "' in " + dbc_path);
        continue;
      }
      const auto sigs = n->child("signals", !spec.required.empty());
      auto bind = [&](std::string_view role, bool required) {
        if (!sigs) return;
        if (!sigs->has(role)) {
          if (required) sigs->fail(role, "required role '" + std::string(role) + "' is not mapped");
          return;
        }
        const std::string name = sigs->get_string(role);
        const dbc::Signal* s = rm.message->find(name);
        if (s == nullptr) {
          sigs->fail(role, "no signal '" + name + "' in message " + msg);
          return;
        }
        rm.signals.emplace(std::string(role), s);
      };
      for (auto r : spec.required) bind(r, true);
      for (auto r : spec.optional) bind(r, false);
      if (sigs) {
        for (const auto& kv : sigs->yaml()) {
          bool known = false;
          for (auto r : spec.required) known = known || r == kv.first.Scalar();
          for (auto r : spec.optional) known = known || r == kv.first.Scalar();
          if (!known) sigs->fail(kv.first.Scalar(), "unknown role for " + std::string(spec.role));
        }
      }
      rm.e2e = e2e_base;
      const bool has_counter = n->has("counter");
      const bool has_crc = n->has("crc");
      if (!has_counter && !has_crc) {
        rm.e2e.profile = safety::E2eProfile::none;
      } else {
        if (has_counter) {
          const std::string cname = n->get_string("counter");
          const dbc::Signal* c = rm.message->find(cname);
          if (c == nullptr || !nibble_of(*c, rm.e2e.counter_byte, rm.e2e.counter_high_nibble)) {
            n->fail("counter", "'" + cname + "' must be a 4-bit, nibble-aligned signal of " + msg);
          }
        } else {
          n->fail("counter", "E2E needs a counter signal when a CRC is mapped");
        }
        if (has_crc) {
          const std::string cname = n->get_string("crc");
          const dbc::Signal* c = rm.message->find(cname);
          if (c == nullptr || !byte_of(*c, rm.e2e.crc_byte)) {
            n->fail("crc", "'" + cname + "' must be an 8-bit, byte-aligned signal of " + msg);
          }
        } else if (safety::has_crc(rm.e2e.profile)) {
          rm.e2e.profile = safety::E2eProfile::counter;
        }
        rm.e2e.data_id = static_cast<std::uint16_t>(n->get_int("data_id", 0, 0xFFFF, 0));
        for (std::size_t i = 0; i < 16; ++i) {
          rm.e2e.data_id_list[i] = static_cast<std::uint8_t>((rm.e2e.data_id + i) & 0xFF);
        }
      }
      out.push_back(std::move(rm));
    }
  };
  load_group("tx", kTxSpecs, p.tx_);
  load_group("rx", kRxSpecs, p.rx_);
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

bool Protocol::encode(const RoleMessage& rm, std::initializer_list<std::pair<std::string_view, double>> values,
                      safety::E2eSender* e2e, can::Frame& out, int* clamped) const noexcept {
  out = can::Frame{};
  out.id = rm.message->id;
  out.extended = rm.message->extended;
  out.len = rm.message->size;
  out.fd = rm.message->size > can::kClassicMaxLen;
  for (const auto& [role, v] : values) {
    const dbc::Signal* s = rm.signal(role);
    if (s == nullptr) continue;
    const auto st = dbc::encode(*s, v, out.payload());
    if (st == dbc::EncodeStatus::not_finite || st == dbc::EncodeStatus::out_of_frame) return false;
    if (st == dbc::EncodeStatus::clamped && clamped != nullptr) ++*clamped;
  }
  if (e2e != nullptr && rm.e2e.profile != safety::E2eProfile::none) return e2e->protect(out.payload());
  return true;
}

std::optional<double> Protocol::value(const RoleMessage& rm, std::string_view role, const can::Frame& f) noexcept {
  const dbc::Signal* s = rm.signal(role);
  if (s == nullptr) return std::nullopt;
  return dbc::decode(*s, f.payload());
}

}  // namespace sensor_rig::dbw
