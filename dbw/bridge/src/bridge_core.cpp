#include "sensor_rig/dbw/bridge/bridge_core.hpp"

#include <limits>
#include <string_view>
#include <utility>

#include "sensor_rig/dbw/dbc/codec.hpp"

namespace sensor_rig::dbw {

safety::SafetyConfig safety_config(const Protocol& p) {
  safety::SafetyConfig c;
  c.command_timeout_ns = p.timing().command_timeout_ns;
  c.ecu_timeout_ns = p.timing().ecu_timeout_ns;
  c.e2e_tolerance = p.e2e_tolerance();
  c.limits = p.limits();
  return c;
}

BridgeCore::BridgeCore(const Protocol& p) : p_(p), safety_(safety_config(p)), schedule_(p.timing().tx_period_ns) {
  static constexpr std::array<std::pair<std::string_view, TxField>, static_cast<std::size_t>(TxField::kCount)> kFields{
      {{"enable", TxField::kEnable},
       {"state", TxField::kState},
       {"mode", TxField::kMode},
       {"angle", TxField::kAngle},
       {"torque", TxField::kTorque},
       {"gear", TxField::kGear},
       {"throttle", TxField::kThrottle},
       {"brake", TxField::kBrake},
       {"accel", TxField::kAccel}}};
  for (const auto& m : p_.tx_messages()) {
    senders_.emplace_back(m.e2e);
    auto& bindings = tx_bindings_.emplace_back();
    for (const auto& [role, sig] : m.signals) {
      for (const auto& [name, field] : kFields) {
        if (name == role) bindings.push_back({sig, field, m.scale(role)});
      }
    }
  }
  for (const auto& m : p_.rx_messages()) {
    checkers_.emplace_back(m.e2e);
    loss_.emplace_back(m.e2e);
    feeds_state_.push_back(m.signal("speed") != nullptr || m.signal("steering_angle") != nullptr ||
                           m.signal("yaw_rate") != nullptr);
  }
}

std::uint64_t BridgeCore::feedback_lost() const noexcept {
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < loss_.size(); ++i)
    if (feeds_state_[i]) n += loss_[i].lost();
  return n + feedback_not_delivered_;
}

std::uint64_t BridgeCore::feedback_gaps_unknown() const noexcept {
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < loss_.size(); ++i)
    if (feeds_state_[i]) n += loss_[i].gaps_unknown();
  return n;
}

bool BridgeCore::on_command(const safety::Command& c, Nanos now, Nanos vehicle_now) {
  const auto applied = safety_.counters().applied;
  safety_.on_command(c, now, vehicle_now);
  return safety_.counters().applied != applied || safety_.transitions() != transitions_sent_;
}

bool BridgeCore::transmit_due(Nanos now, bool command_changed) {
  (void)safety_.tick(now);
  if (safety_.transitions() != transitions_sent_) return true;
  if (safety_.counters().applied != applied_sent_) {
    if (schedule_.command_may_go(now)) return true;
    if (command_changed) ++counters_.commands_deferred;
  }
  return schedule_.periodic_due(now);
}

// Applies every role the message maps; a message may carry status and feedback roles at once.
RxKind BridgeCore::on_frame(const can::RxFrame& rx, Nanos now) {
  ++counters_.frames_received;
  if (rx.frame.error) return RxKind::kErrorFrame;
  const auto& rxm = p_.rx_messages();
  for (std::size_t i = 0; i < rxm.size(); ++i) {
    const RoleMessage& rm = rxm[i];
    if (!rm.matches(rx.frame)) continue;
    const bool protected_msg = rm.e2e.profile != safety::E2eProfile::kNone;
    if (rx.frame.len < rm.message->size) {
      if (protected_msg) safety_.on_e2e(false, now);
      loss_[i].on_frame(rx.frame.payload(), safety::E2eStatus::kBadLayout, now);
      return RxKind::kE2eError;
    }
    if (protected_msg) {
      const safety::E2eStatus st = checkers_[i].check(rx.frame.payload());
      loss_[i].on_frame(rx.frame.payload(), st, now);
      const bool ok = safety::is_ok(st);
      safety_.on_e2e(ok, now);
      if (!ok) return RxKind::kE2eError;
    }
    auto has = [&](std::string_view role) { return rm.signal(role) != nullptr; };
    auto get = [&](std::string_view role, double fallback) { return Protocol::value(rm, role, rx.frame).value_or(fallback); };
    RxKind kind = RxKind::kOther;
    if (has("fl")) {
      fb_.wheels[0] = get("fl", fb_.wheels[0]);
      fb_.wheels[1] = get("fr", fb_.wheels[1]);
      fb_.wheels[2] = get("rl", fb_.wheels[2]);
      fb_.wheels[3] = get("rr", fb_.wheels[3]);
      kind = RxKind::kWheels;
    }
    if (has("speed") || has("steering_angle") || has("yaw_rate")) {
      fb_.stamp = rx.stamp;
      fb_.speed = get("speed", fb_.speed);
      fb_.steering_angle = get("steering_angle", fb_.steering_angle);
      fb_.yaw_rate = get("yaw_rate", fb_.yaw_rate);
      if (has("gear")) fb_.gear = static_cast<int>(get("gear", 0.0));
      // Only what this message measured (NaN: unchanged).
      constexpr double kKeep = std::numeric_limits<double>::quiet_NaN();
      safety_.on_measured(has("steering_angle") ? fb_.steering_angle : kKeep, has("speed") ? fb_.speed : kKeep);
      kind = RxKind::kFeedback;
    }
    if (has("ready") || has("override") || has("fault")) {
      // The message carrying the ECU's readiness is its heartbeat: every one refreshes the status.
      auto flag = [&](std::string_view role, bool current) { return has(role) ? get(role, 0.0) > 0.5 : current; };
      ecu_.ready = flag("ready", ecu_.ready);
      ecu_.engaged = flag("engaged", ecu_.engaged);
      ecu_.override = flag("override", ecu_.override);
      ecu_.fault = flag("fault", ecu_.fault);
      if (has("fault_code")) ecu_.fault_code = static_cast<std::uint8_t>(get("fault_code", 0.0));
      safety_.on_ecu_status(ecu_, now);
      ++counters_.status_frames;
      if (kind == RxKind::kOther) kind = RxKind::kStatus;
    }
    return kind;
  }
  return RxKind::kOther;
}

// Every tx message gets every command value it maps (and the enable of the decision): a protocol may
// spread steering, throttle, brake, gear and enable over as many messages as it likes.
void BridgeCore::frames(Nanos now, std::vector<can::Frame>& out) {
  const safety::Decision d = safety_.tick(now);
  transitions_sent_ = safety_.transitions();
  schedule_.sent(now, safety_.counters().applied != applied_sent_);
  applied_sent_ = safety_.counters().applied;
  const double en = d.active ? 1.0 : 0.0;
  const safety::Command& c = d.command;  // zeros when not active: the neutral/disengage request
  std::array<double, static_cast<std::size_t>(TxField::kCount)> v{};
  v[static_cast<std::size_t>(TxField::kEnable)] = en;
  v[static_cast<std::size_t>(TxField::kState)] = en;
  v[static_cast<std::size_t>(TxField::kAngle)] = c.steering_angle;
  v[static_cast<std::size_t>(TxField::kTorque)] = c.steering_torque;
  v[static_cast<std::size_t>(TxField::kGear)] = static_cast<double>(c.gear);
  v[static_cast<std::size_t>(TxField::kThrottle)] = c.throttle;
  v[static_cast<std::size_t>(TxField::kBrake)] = c.brake;
  v[static_cast<std::size_t>(TxField::kAccel)] = c.accel;
  const auto& txm = p_.tx_messages();
  for (std::size_t i = 0; i < txm.size(); ++i) {
    can::Frame f;
    bool ok = Protocol::start_frame(txm[i], f);
    for (const auto& b : tx_bindings_[i]) {
      const auto st = dbc::encode(*b.signal, v[static_cast<std::size_t>(b.field)] * b.scale, f.payload());
      ok = ok && st != dbc::EncodeStatus::kNotFinite && st != dbc::EncodeStatus::kOutOfFrame;
    }
    if (ok && txm[i].e2e.profile != safety::E2eProfile::kNone) ok = senders_[i].protect(f.payload());
    if (ok) {
      out.push_back(f);
    } else {
      ++counters_.encode_errors;
    }
  }
}

}  // namespace sensor_rig::dbw
