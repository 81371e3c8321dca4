#include "sensor_rig/dbw/safety/safety_core.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace sensor_rig::dbw::safety {

std::string_view to_string(State s) noexcept { return s == State::kEngaged ? "engaged" : "disengaged"; }

std::string_view to_string(Reason r) noexcept {
  switch (r) {
    case Reason::kNone: return "none";
    case Reason::kEnabled: return "enabled";
    case Reason::kEnableReleased: return "enable_released";
    case Reason::kCommandTimeout: return "command_timeout";
    case Reason::kEcuTimeout: return "ecu_timeout";
    case Reason::kE2eErrors: return "e2e_errors";
    case Reason::kDriverOverride: return "driver_override";
    case Reason::kEcuFault: return "ecu_fault";
    case Reason::kEcuNotReady: return "ecu_not_ready";
    case Reason::kInvalidCommand: return "invalid_command";
    case Reason::kBusOff: return "bus_off";
    case Reason::kNoCommand: return "no_command";
    case Reason::kNotOwner: return "not_owner";
    case Reason::kShutdown: return "shutdown";
  }
  return "?";
}

std::string_view to_string(EventKind k) noexcept {
  switch (k) {
    case EventKind::kTransition: return "transition";
    case EventKind::kEngageRefused: return "engage_refused";
    case EventKind::kLimit: return "limit";
    case EventKind::kCommandIgnored: return "command_ignored";
    case EventKind::kFault: return "fault";
  }
  return "?";
}

namespace {
// One bit per (axis, kind of limit).
std::uint32_t violation_bit(const Violation& v) noexcept {
  const unsigned kind = v.not_finite ? 0U : v.rate ? 1U : v.lateral ? 2U : v.interlock ? 3U : 4U;
  return 1U << (static_cast<unsigned>(v.axis) * 5U + kind);
}
}  // namespace

SafetyCore::SafetyCore(const SafetyConfig& cfg) : cfg_(cfg), checker_(cfg.limits) {}

void SafetyCore::emit(Nanos now, EventKind k, Reason r, const Violation& v) {
  if (n_events_ == events_.size()) {
    ++counters_.events_dropped;
    return;
  }
  events_[n_events_++] = Event{now, k, state_, r, v};
}

std::vector<Event> SafetyCore::take_events() {
  std::vector<Event> out(events().begin(), events().end());
  clear_events();
  return out;
}

bool SafetyCore::has_fresh_command(Nanos now) const noexcept {
  return state_ == State::kEngaged && now - last_cmd_rx_ <= cfg_.command_timeout_ns;
}

bool SafetyCore::ecu_fresh(Nanos now) const noexcept { return have_ecu_ && now - last_ecu_ <= cfg_.ecu_timeout_ns; }

Reason SafetyCore::engage_blocker(Nanos now) const noexcept {
  if (stopping_) return Reason::kShutdown;
  if (bus_off_) return Reason::kBusOff;
  if (!ecu_fresh(now)) return Reason::kEcuTimeout;
  if (ecu_.override) return Reason::kDriverOverride;
  if (ecu_.fault) return Reason::kEcuFault;
  if (!ecu_.ready) return Reason::kEcuNotReady;
  if (e2e_level_ > cfg_.e2e_tolerance) return Reason::kE2eErrors;
  return Reason::kNone;
}

WriterState& SafetyCore::writer(WriterId id) noexcept {
  WriterState* oldest = nullptr;
  for (auto& w : writers_) {
    if (w.used && w.id == id) return w;
  }
  for (auto& w : writers_) {
    if (!w.used) {
      w = WriterState{id};
      return w;
    }
    const bool owns = state_ == State::kEngaged && w.id == owner_;
    if (!owns && (oldest == nullptr || w.last_rx < oldest->last_rx)) oldest = &w;
  }
  *oldest = WriterState{id};  // forgotten: it must show a new edge to engage
  return *oldest;
}

void SafetyCore::disarm_all() noexcept {
  for (auto& w : writers_) w.armed = false;
}

void SafetyCore::engage(WriterState& w, const Command& applied, Nanos now) {
  w.armed = false;  // an edge is used once, engaged or refused
  const Reason block = engage_blocker(now);
  if (block != Reason::kNone) {
    emit(now, EventKind::kEngageRefused, block);
    return;
  }
  state_ = State::kEngaged;
  reason_ = Reason::kEnabled;
  owner_ = w.id;
  ++counters_.applied;
  latest_ = applied;
  last_cmd_rx_ = now;
  checker_.accept(applied);
  ++counters_.engagements;
  emit(now, EventKind::kTransition, Reason::kEnabled);
}

void SafetyCore::disengage(Reason r, Nanos now) {
  if (state_ != State::kEngaged) return;
  state_ = State::kDisengaged;
  reason_ = r;
  owner_ = 0;
  ++counters_.disengagements;
  checker_.reset();
  disarm_all();  // every writer must show false then true again
  emit(now, EventKind::kTransition, r);
}

void SafetyCore::on_command(const Command& cmd, Nanos now, Nanos vehicle_now) {
  ++counters_.commands;
  // A disable from any writer takes effect at once, whatever its seq or stamp: stopping is safe.
  if (!cmd.enable) disengage(Reason::kEnableReleased, now);
  WriterState& w = writer(cmd.writer);
  if (w.used && cmd.seq <= w.last_seq) {
    ++counters_.ignored_sequence;
    emit(now, EventKind::kCommandIgnored, Reason::kNone);
    return;
  }
  const Nanos age = vehicle_now - cmd.stamp;
  if (age > cfg_.command_timeout_ns || age < -cfg_.max_future_ns) {
    ++counters_.ignored_stale;
    emit(now, EventKind::kCommandIgnored, Reason::kCommandTimeout);
    return;
  }
  if (w.used && cmd.stamp <= w.last_stamp) {
    // A later seq with an equal or earlier stamp: no time has passed for it, so it can carry no change.
    ++counters_.ignored_stamp;
    emit(now, EventKind::kCommandIgnored, Reason::kInvalidCommand);
    return;
  }
  const Nanos rate_dt = w.used && w.valid ? std::min(cmd.stamp - w.last_stamp, now - w.last_rx + cfg_.rate_rx_slack_ns) : 0;
  w.used = true;
  w.last_seq = cmd.seq;
  w.last_stamp = cmd.stamp;
  w.last_rx = now;
  if (state_ == State::kEngaged && w.id != owner_) {
    w.valid = true;
    ++counters_.ignored_writer;
    emit(now, EventKind::kCommandIgnored, Reason::kNotOwner);
    return;
  }
  const bool engaging = state_ == State::kDisengaged && cmd.enable && w.armed;
  if (engaging) {
    // Rate limits start from the actuators as measured, not from a step out of nothing.
    Command measured{};
    measured.steering_angle = measured_steering_;
    checker_.accept(measured);
  } else if (state_ == State::kDisengaged) {
    checker_.reset();  // nothing is applied: range checks only
  }
  const LimitResult lr = checker_.check(cmd, static_cast<double>(rate_dt) * 1e-9, measured_speed_);
  if (lr.rejected()) {
    ++counters_.rejected;
    w.valid = false;
    w.armed = false;  // a rejected command cannot be half of an enable edge
    emit(now, EventKind::kLimit, Reason::kInvalidCommand, lr.violations[0]);
    disengage(Reason::kInvalidCommand, now);
    return;
  }
  // Each kind of violation is reported when it starts (a run of clamped commands: one event).
  std::uint32_t kinds = 0;
  for (std::size_t i = 0; i < lr.count; ++i) {
    const std::uint32_t bit = violation_bit(lr.violations[i]);
    if ((reported_limits_ & bit) == 0) emit(now, EventKind::kLimit, Reason::kNone, lr.violations[i]);
    kinds |= bit;
  }
  reported_limits_ = kinds;
  if (lr.count > 0) ++counters_.clamped;
  w.valid = true;
  if (!cmd.enable) {
    w.armed = true;
  } else if (state_ == State::kEngaged) {
    ++counters_.applied;
    latest_ = lr.applied;
    last_cmd_rx_ = now;
    checker_.accept(lr.applied);
  } else if (engaging) {
    engage(w, lr.applied, now);
  }
}

void SafetyCore::on_ecu_status(const EcuStatus& st, Nanos now) {
  ecu_ = st;
  have_ecu_ = true;
  last_ecu_ = now;
  if (state_ != State::kEngaged) return;
  if (st.override) {
    disengage(Reason::kDriverOverride, now);
  } else if (st.fault) {
    disengage(Reason::kEcuFault, now);
  } else if (!st.ready) {
    disengage(Reason::kEcuNotReady, now);
  }
}

void SafetyCore::on_e2e(bool ok, Nanos now) {
  if (ok) {
    if (e2e_level_ > 0) --e2e_level_;
    return;
  }
  ++counters_.e2e_errors;
  e2e_level_ = std::min(e2e_level_ + 1, e2e_level_max(cfg_));
  if (e2e_level_ == cfg_.e2e_tolerance + 1) emit(now, EventKind::kFault, Reason::kE2eErrors);
  if (e2e_level_ > cfg_.e2e_tolerance) disengage(Reason::kE2eErrors, now);
}

void SafetyCore::on_bus_state(bool bus_off, Nanos now) {
  if (bus_off && !bus_off_) emit(now, EventKind::kFault, Reason::kBusOff);
  bus_off_ = bus_off;
  if (bus_off) disengage(Reason::kBusOff, now);
}

void SafetyCore::on_measured(double steering_angle, double speed_mps) noexcept {
  if (std::isfinite(steering_angle)) measured_steering_ = steering_angle;
  if (std::isfinite(speed_mps)) measured_speed_ = speed_mps;
}

void SafetyCore::shutdown(Nanos now) {
  stopping_ = true;
  disengage(Reason::kShutdown, now);
}

Decision SafetyCore::tick(Nanos now) {
  if (state_ == State::kEngaged) {
    if (now - last_cmd_rx_ > cfg_.command_timeout_ns) {
      disengage(Reason::kCommandTimeout, now);
    } else if (!ecu_fresh(now)) {
      disengage(Reason::kEcuTimeout, now);
    }
  }
  Decision d;
  d.state = state_;
  d.active = state_ == State::kEngaged;
  if (d.active) d.command = latest_;
  return d;
}

}  // namespace sensor_rig::dbw::safety
