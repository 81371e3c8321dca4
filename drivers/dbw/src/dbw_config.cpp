#include "sensor_rig/drivers/dbw/dbw_config.hpp"

#include <filesystem>
#include <stdexcept>

#include "sensor_rig/dds/security.hpp"

namespace sensor_rig::drivers {

namespace {
// `security: {dir, enabled, bridge_identity, command_identity}`: the directory must hold the
// identities the bridge (and an enabled command source) run as — checked now, not when rig up starts them.
void parse_security(const config::Node& s, DbwConfig& d) {
  s.allow_keys({"dir", "enabled", "bridge_identity", "command_identity"});
  auto& sec = d.security;
  sec.enabled = s.get_bool("enabled", true);
  sec.dir = s.get_path("dir");
  sec.bridge_identity = s.get_string("bridge_identity", sec.bridge_identity);
  sec.command_identity = s.get_string("command_identity", sec.command_identity);
  if (!sec.enabled || sec.dir.empty()) return;  // a missing dir is already reported
  if (!std::filesystem::is_directory(sec.dir)) {
    s.fail("dir", "not a directory: " + sec.dir + " (`rig security init DIR` creates one)");
    return;
  }
  const auto check = [&](const char* key, const std::string& identity) {
    try {
      (void)dds::security_files(sec.dir, identity);
    } catch (const std::runtime_error& e) {
      s.fail(s.has(key) ? key : "dir", e.what());
    }
  };
  check("bridge_identity", sec.bridge_identity);
  if (d.command_source.enabled) check("command_identity", sec.command_identity);
}
}  // namespace

DbwConfig parse_dbw_config(const config::Node& n) {
  DbwConfig d;
  d.enabled = true;
  n.allow_keys({"protocol", "bus", "transport", "mock_ecu", "mock_faults", "command_source", "realtime_priority",
                "security"});
  d.realtime_priority = static_cast<int>(n.get_int("realtime_priority", 0, 98, 30));
  d.protocol = n.get_path("protocol", "");
  if (!d.protocol.empty() && !std::filesystem::exists(d.protocol)) n.fail("protocol", "file not found: " + d.protocol);
  d.bus = n.get_string("bus", d.bus);
  d.transport = n.get_string("transport", "");
  d.mock_ecu = n.get_bool("mock_ecu", false);
  for (const auto& f : n.items("mock_faults")) {
    if (!f.yaml().IsScalar()) {
      f.fail("", "expected a fault string like 'loss=0.01' or 'override@5+1'");
      continue;
    }
    d.mock_faults.push_back(f.yaml().Scalar());
  }
  if (auto c = n.child("command_source")) {
    c->allow_keys({"enabled", "rate_hz", "steer_rad", "throttle", "brake", "gear"});
    auto& cs = d.command_source;
    cs.enabled = c->get_bool("enabled", true);
    cs.rate_hz = c->get_double("rate_hz", 1, 1000, 50);
    cs.steer_rad = c->get_double("steer_rad", -1.0, 1.0, 0.05);
    cs.throttle = c->get_double("throttle", 0, 1, 0.2);
    cs.brake = c->get_double("brake", 0, 1, 0.0);
    cs.gear = static_cast<int>(c->get_int("gear", 0, 4, 4));
  }
  if (auto s = n.child("security")) parse_security(*s, d);
  return d;
}

std::vector<std::string> security_args(const DbwConfig& d, bool bridge) {
  if (!d.security.enabled) return {};
  return {"--security", d.security.dir, "--identity",
          bridge ? d.security.bridge_identity : d.security.command_identity};
}

}  // namespace sensor_rig::drivers
