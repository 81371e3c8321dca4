#include "sensor_rig/dbw/safety/safety_core.hpp"

#include <algorithm>
#include <utility>

namespace sensor_rig::dbw::safety {

std::string_view to_string(State s) noexcept { return s == State::engaged ? "engaged" : "disengaged"; }

std::string_view to_string(Reason r) noexcept {
  switch (r) {
    case Reason::none: return "none";
    case Reason::enabled: return "enabled";
    case Reason::enable_released: return "enable_released";
    case Reason::command_timeout: return "command_timeout";
    case Reason::ecu_timeout: return "ecu_timeout";
    case Reason::e2e_errors: return "e2e_errors";
    case Reason::driver_override: return "driver_override";
    case Reason::ecu_fault: return "ecu_fault";
    case Reason::ecu_not_ready: return "ecu_not_ready";
    case Reason::invalid_command: return "invalid_command";
    case Reason::bus_off: return "bus_off";
    case Reason::no_command: return "no_command";
  }
  return "?";
}

std::string_view to_string(EventKind k) noexcept {
  switch (k) {
    case EventKind::transition: return "transition";
    case EventKind::engage_refused: return "engage_refused";
    case EventKind::limit: return "limit";
    case EventKind::command_ignored: return "command_ignored";
    case EventKind::fault: return "fault";
  }
  return "?";
}

SafetyCore::SafetyCore(const SafetyConfig& cfg) : cfg_(cfg), checker_(cfg.limits) { events_.reserve(64); }

void SafetyCore::emit(Nanos now, EventKind k, Reason r, const Violation& v) {
  events_.push_back(Event{now, k, state_, r, v});
}

std::vector<Event> SafetyCore::take_events() {
  std::vector<Event> out;
  out.swap(events_);
  events_.reserve(64);
  return out;
}

bool SafetyCore::has_fresh_command(Nanos now) const noexcept {
  return have_cmd_ && cmd_valid_ && now - last_cmd_stamp_ <= cfg_.command_timeout_ns;
}

bool SafetyCore::ecu_fresh(Nanos now) const noexcept { return have_ecu_ && now - last_ecu_ <= cfg_.ecu_timeout_ns; }

Reason SafetyCore::engage_blocker(Nanos now) const noexcept {
  if (!has_fresh_command(now)) return Reason::no_command;
  if (bus_off_) return Reason::bus_off;
  if (!ecu_fresh(now)) return Reason::ecu_timeout;
  if (ecu_.override) return Reason::driver_override;
  if (ecu_.fault) return Reason::ecu_fault;
  if (!ecu_.ready) return Reason::ecu_not_ready;
  if (e2e_level_ > cfg_.e2e_tolerance) return Reason::e2e_errors;
  return Reason::none;
}

void SafetyCore::engage(Nanos now) {
  const Reason block = engage_blocker(now);
  if (block != Reason::none) {
    emit(now, EventKind::engage_refused, block);
    return;
  }
  state_ = State::engaged;
  reason_ = Reason::enabled;
  ++counters_.engagements;
  emit(now, EventKind::transition, Reason::enabled);
}

void SafetyCore::disengage(Reason r, Nanos now) {
  if (state_ != State::engaged) return;
  state_ = State::disengaged;
  reason_ = r;
  ++counters_.disengagements;
  checker_.reset();
  emit(now, EventKind::transition, r);
}

void SafetyCore::on_command(const Command& cmd, Nanos now) {
  ++counters_.commands;
  if (have_cmd_ && cmd.seq <= last_seq_) {
    ++counters_.ignored_sequence;
    emit(now, EventKind::command_ignored, Reason::none);
    return;
  }
  const Nanos age = now - cmd.stamp;
  if (age > cfg_.command_timeout_ns || age < -cfg_.max_future_ns) {
    ++counters_.ignored_stale;
    emit(now, EventKind::command_ignored, Reason::command_timeout);
    return;
  }
  if (have_cmd_ && cmd.stamp <= last_stamp_seen_) {
    // A later seq with an equal or earlier stamp: no time has passed for it, so it can carry no
    // change (and must not reset the freshness of the command it follows).
    ++counters_.ignored_stamp;
    emit(now, EventKind::command_ignored, Reason::invalid_command);
    return;
  }
  // Rates are checked only while engaged (the checker holds no previous command otherwise).
  const Nanos rate_dt = have_cmd_ && cmd_valid_ ? std::min(cmd.stamp - last_cmd_stamp_, now - last_cmd_rx_ + cfg_.rate_rx_slack_ns) : 0;
  const LimitResult lr = checker_.check(cmd, static_cast<double>(rate_dt) * 1e-9);
  have_cmd_ = true;
  last_seq_ = cmd.seq;
  last_stamp_seen_ = cmd.stamp;
  if (lr.rejected()) {
    ++counters_.rejected;
    cmd_valid_ = false;
    emit(now, EventKind::limit, Reason::invalid_command, lr.violations[0]);
    disengage(Reason::invalid_command, now);
    prev_enable_ = cmd.enable;  // a rejected command cannot produce an enable edge later
    return;
  }
  if (lr.count > 0) {
    ++counters_.clamped;
    if (!limit_reported_) emit(now, EventKind::limit, Reason::none, lr.violations[0]);
    limit_reported_ = true;
  } else {
    limit_reported_ = false;
  }
  cmd_valid_ = true;
  latest_ = lr.applied;
  last_cmd_stamp_ = cmd.stamp;
  last_cmd_rx_ = now;
  if (state_ == State::engaged) checker_.accept(lr.applied);
  if (!cmd.enable) {
    disengage(Reason::enable_released, now);
  } else if (!prev_enable_ && state_ == State::disengaged) {
    engage(now);
    if (state_ == State::engaged) checker_.accept(lr.applied);
  }
  prev_enable_ = cmd.enable;
}

void SafetyCore::on_ecu_status(const EcuStatus& st, Nanos now) {
  ecu_ = st;
  have_ecu_ = true;
  last_ecu_ = now;
  if (state_ != State::engaged) return;
  if (st.override) {
    disengage(Reason::driver_override, now);
  } else if (st.fault) {
    disengage(Reason::ecu_fault, now);
  } else if (!st.ready) {
    disengage(Reason::ecu_not_ready, now);
  }
}

void SafetyCore::on_e2e(bool ok, Nanos now) {
  if (ok) {
    if (e2e_level_ > 0) --e2e_level_;
    return;
  }
  ++counters_.e2e_errors;
  ++e2e_level_;
  if (e2e_level_ == cfg_.e2e_tolerance + 1) emit(now, EventKind::fault, Reason::e2e_errors);
  if (e2e_level_ > cfg_.e2e_tolerance) disengage(Reason::e2e_errors, now);
}

void SafetyCore::on_bus_state(bool bus_off, Nanos now) {
  if (bus_off && !bus_off_) emit(now, EventKind::fault, Reason::bus_off);
  bus_off_ = bus_off;
  if (bus_off) disengage(Reason::bus_off, now);
}

Decision SafetyCore::tick(Nanos now) {
  if (state_ == State::engaged) {
    if (!has_fresh_command(now)) {
      disengage(Reason::command_timeout, now);
    } else if (!ecu_fresh(now)) {
      disengage(Reason::ecu_timeout, now);
    }
  }
  Decision d;
  d.state = state_;
  d.active = state_ == State::engaged;
  if (d.active) d.command = latest_;
  return d;
}

}  // namespace sensor_rig::dbw::safety
