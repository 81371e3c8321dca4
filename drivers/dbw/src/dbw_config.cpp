#include "sensor_rig/drivers/dbw/dbw_config.hpp"

#include <filesystem>

namespace sensor_rig::drivers {

DbwConfig parse_dbw_config(const config::Node& n) {
  DbwConfig d;
  d.enabled = true;
  n.allow_keys({"protocol", "bus", "transport", "mock_ecu", "mock_faults", "command_source", "realtime_priority"});
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
  return d;
}

}  // namespace sensor_rig::drivers
