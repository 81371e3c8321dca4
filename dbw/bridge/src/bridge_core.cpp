#include "sensor_rig/dbw/bridge/bridge_core.hpp"

namespace sensor_rig::dbw {

safety::SafetyConfig safety_config(const Protocol& p) {
  safety::SafetyConfig c;
  c.command_timeout_ns = p.timing().command_timeout_ns;
  c.ecu_timeout_ns = p.timing().ecu_timeout_ns;
  c.e2e_tolerance = p.e2e_tolerance();
  c.limits = p.limits();
  return c;
}

BridgeCore::BridgeCore(const Protocol& p) : p_(p), safety_(safety_config(p)) {
  for (const auto& m : p_.tx_messages()) senders_.emplace_back(m.e2e);
  for (const auto& m : p_.rx_messages()) checkers_.emplace_back(m.e2e);
}

RxKind BridgeCore::on_frame(const can::RxFrame& rx, Nanos now) {
  ++counters_.frames_received;
  if (rx.frame.error) return RxKind::error_frame;
  const auto& rxm = p_.rx_messages();
  for (std::size_t i = 0; i < rxm.size(); ++i) {
    const RoleMessage& rm = rxm[i];
    if (!rm.matches(rx.frame)) continue;
    const bool protected_msg = rm.e2e.profile != safety::E2eProfile::none;
    if (rx.frame.len < rm.message->size) {
      if (protected_msg) safety_.on_e2e(false, now);
      return RxKind::e2e_error;
    }
    if (protected_msg) {
      const bool ok = safety::is_ok(checkers_[i].check(rx.frame.payload()));
      safety_.on_e2e(ok, now);
      if (!ok) return RxKind::e2e_error;
    }
    auto get = [&](std::string_view role) { return Protocol::value(rm, role, rx.frame).value_or(0.0); };
    if (rm.role == "status") {
      ecu_.ready = get("ready") > 0.5;
      ecu_.engaged = get("engaged") > 0.5;
      ecu_.override = get("override") > 0.5;
      ecu_.fault = get("fault") > 0.5;
      ecu_.fault_code = static_cast<std::uint8_t>(get("fault_code"));
      safety_.on_ecu_status(ecu_, now);
      return RxKind::status;
    }
    if (rm.role == "feedback") {
      fb_.stamp = rx.stamp;
      fb_.speed = get("speed");
      fb_.steering_angle = get("steering_angle");
      fb_.yaw_rate = get("yaw_rate");
      fb_.gear = static_cast<int>(get("gear"));
      return RxKind::feedback;
    }
    if (rm.role == "wheels") {
      fb_.wheels[0] = get("fl");
      fb_.wheels[1] = get("fr");
      fb_.wheels[2] = get("rl");
      fb_.wheels[3] = get("rr");
      return RxKind::wheels;
    }
  }
  return RxKind::other;
}

void BridgeCore::frames(Nanos now, std::vector<can::Frame>& out) {
  const safety::Decision d = safety_.tick(now);
  const auto& txm = p_.tx_messages();
  for (std::size_t i = 0; i < txm.size(); ++i) {
    const RoleMessage& rm = txm[i];
    can::Frame f;
    bool ok = false;
    const double en = d.active ? 1.0 : 0.0;
    const safety::Command& c = d.command;  // zeros when not active: the neutral/disengage request
    if (rm.role == "steering") {
      ok = p_.encode(rm, {{"enable", en}, {"mode", 0}, {"angle", c.steering_angle}, {"torque", c.steering_torque}},
                     &senders_[i], f);
    } else if (rm.role == "longitudinal") {
      ok = p_.encode(rm, {{"enable", en}, {"gear", static_cast<double>(c.gear)}, {"throttle", c.throttle},
                          {"brake", c.brake}, {"accel", c.accel}},
                     &senders_[i], f);
    } else if (rm.role == "heartbeat") {
      ok = p_.encode(rm, {{"state", en}}, &senders_[i], f);
    }
    if (ok) {
      out.push_back(f);
    } else {
      ++counters_.encode_errors;
    }
  }
}

}  // namespace sensor_rig::dbw
