#include "sensor_rig/dbw/mock/mock_ecu.hpp"

#include <cstdlib>
#include <stdexcept>

#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::mock {

Fault parse_fault(const std::string& spec) {
  Fault f;
  std::string name = spec;
  auto take = [&name](char sep, double& out) {
    const auto pos = name.rfind(sep);
    if (pos == std::string::npos) return;
    const std::string num = name.substr(pos + 1);
    char* end = nullptr;
    out = std::strtod(num.c_str(), &end);
    if (num.empty() || *end != '\0' || out < 0) throw std::invalid_argument("fault '" + name + "': bad number '" + num + "'");
    name.erase(pos);
  };
  take('+', f.duration_s);
  take('@', f.start_s);
  take('=', f.value);
  if (name == "loss") f.kind = FaultKind::kFrameLoss;
  else if (name == "bad-crc") f.kind = FaultKind::kBadCrc;
  else if (name == "stuck-counter") f.kind = FaultKind::kStuckCounter;
  else if (name == "override") f.kind = FaultKind::kDriverOverride;
  else if (name == "ecu-fault") f.kind = FaultKind::kEcuFault;
  else if (name == "bus-off") f.kind = FaultKind::kBusOff;
  else if (name == "no-status") f.kind = FaultKind::kNoStatus;
  else throw std::invalid_argument("unknown fault '" + name + "' (loss=P, bad-crc, stuck-counter, override, ecu-fault, bus-off, no-status; [@start][+duration])");
  if (f.kind == FaultKind::kFrameLoss && (f.value < 0.0 || f.value > 1.0)) throw std::invalid_argument("loss probability must be 0..1");
  return f;
}

MockEcu::MockEcu(const Protocol& protocol, std::vector<Fault> faults, std::uint64_t seed)
    : p_(protocol), faults_(std::move(faults)), rng_(seed) {
  for (const auto& m : p_.tx_messages()) checkers_.emplace_back(m.e2e);
  for (const auto& m : p_.rx_messages()) senders_.emplace_back(m.e2e);
  last_counter_.assign(senders_.size(), -1);
  e2e_level_.assign(checkers_.size(), 0);
}

const Fault* MockEcu::fault_active(FaultKind k, double t_s) const noexcept {
  for (const auto& f : faults_)
    if (f.kind == k && f.active(t_s)) return &f;
  return nullptr;
}

void MockEcu::disengage(const std::string& why) {
  if (engaged_) last_disengage_ = why;
  engaged_ = false;
}

void MockEcu::on_frame(const can::Frame& f, Nanos now) {
  if (bus_off_) return;  // a bus-off controller takes no part in the bus
  const auto& tx = p_.tx_messages();
  for (std::size_t i = 0; i < tx.size(); ++i) {
    const RoleMessage& rm = tx[i];
    if (!rm.matches(f)) continue;
    ++counters_.rx_frames;
    if (f.len < rm.message->size) {
      ++counters_.rx_e2e_errors;
      return;
    }
    const auto st = checkers_[i].check(f.payload());
    if (!safety::is_ok(st)) {
      ++counters_.rx_e2e_errors;
      if (++e2e_level_[i] > p_.e2e_tolerance()) disengage("e2e errors on " + rm.message->name);
      return;
    }
    if (e2e_level_[i] > 0) --e2e_level_[i];
    auto get = [&](std::string_view role, double dflt) { return Protocol::value(rm, role, f).value_or(dflt); };
    if (rm.role == "steering") {
      last_steer_ = now;
      steer_enable_ = get("enable", 0) > 0.5;
      req_.steer = get("angle", 0.0);
    } else if (rm.role == "longitudinal") {
      last_long_ = now;
      long_enable_ = get("enable", 0) > 0.5;
      req_.throttle = get("throttle", 0.0);
      req_.brake = get("brake", 0.0);
      req_.gear = static_cast<safety::Gear>(static_cast<int>(get("gear", 0.0)));
    } else if (rm.role == "heartbeat") {
      last_heartbeat_ = now;
    }
    return;
  }
}

void MockEcu::emit(std::size_t index, std::initializer_list<std::pair<std::string_view, double>> values, double t_s,
                   Nanos now, std::vector<can::Frame>& out) {
  const RoleMessage& rm = p_.rx_messages()[index];
  safety::E2eSender& sender = senders_[index];
  can::Frame f;
  const bool protected_msg = rm.e2e.profile != safety::E2eProfile::kNone;
  const Fault* stuck = fault_active(FaultKind::kStuckCounter, t_s);
  // A counter that unfreezes counts on from its frozen value: the first frame after the fault is not
  // one more repeat (it was, and its truth said "sent": rig chaos saw the bridge refuse a sent frame).
  if (stuck == nullptr && protected_msg && last_counter_[index] == sender.next_counter())
    sender.set_counter(static_cast<std::uint8_t>(sender.next_counter() + 1));
  const std::uint8_t counter = sender.next_counter();
  if (!p_.encode(rm, values, &sender, f)) return;
  EmittedFrame e;
  e.role = rm.role;
  e.now = now;
  // A frozen counter: this frame gets the value the last one had (the first of the fault still counts on).
  if (stuck != nullptr) {
    sender.set_counter(counter);
    if (protected_msg && last_counter_[index] == counter) e = {rm.role, EmittedFrame::Fate::kRepeatedCounter, stuck->id, now};
  }
  last_counter_[index] = counter;
  if (const Fault* bad = fault_active(FaultKind::kBadCrc, t_s); bad != nullptr && safety::has_crc(rm.e2e.profile)) {
    f.data[rm.e2e.crc_byte] ^= 0x5A;
    e = {rm.role, EmittedFrame::Fate::kBadCrc, bad->id, now};
  }
  if (const Fault* loss = fault_active(FaultKind::kFrameLoss, t_s);
      loss != nullptr && std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < loss->value) {
    ++counters_.tx_dropped;
    if (observer_) observer_({rm.role, EmittedFrame::Fate::kDropped, loss->id, now});
    return;
  }
  ++counters_.tx_frames;
  if (observer_) observer_(e);
  out.push_back(f);
}

std::vector<can::Frame> MockEcu::step(Nanos now) {
  std::vector<can::Frame> out;
  if (start_ < 0) {
    start_ = now;
    last_step_ = now;
    next_status_ = now;
    next_wheels_ = now;
  }
  const double t_s = static_cast<double>(now - start_) * 1e-9;
  const double dt = static_cast<double>(now - last_step_) * 1e-9;
  last_step_ = now;

  const bool bus_off_now = fault_active(FaultKind::kBusOff, t_s) != nullptr;
  if (bus_off_now && !bus_off_) {
    bus_off_ = true;
    disengage("bus-off");
    out.push_back(can::make_error_frame(true, false));
  } else if (!bus_off_now && bus_off_) {
    bus_off_ = false;
    out.push_back(can::make_error_frame(false, true));
  }
  const bool override_now = fault_active(FaultKind::kDriverOverride, t_s) != nullptr;
  const bool fault_now = fault_active(FaultKind::kEcuFault, t_s) != nullptr;
  if (override_now) disengage("driver override");
  if (fault_now) disengage("ecu fault");

  const Nanos timeout = p_.timing().command_timeout_ns;
  const bool has_hb = p_.tx("heartbeat") != nullptr;
  const bool fresh = last_steer_ >= 0 && last_long_ >= 0 && now - last_steer_ <= timeout && now - last_long_ <= timeout &&
                     (!has_hb || (last_heartbeat_ >= 0 && now - last_heartbeat_ <= timeout));
  const bool enable_bits = steer_enable_ && long_enable_;
  const bool requested = fresh && enable_bits;
  if (engaged_ && !fresh) {
    ++counters_.pu_timeouts;
    disengage("pu timeout");
  } else if (engaged_ && !requested) {
    disengage("released by pu");
  }
  int worst = 0;
  for (int l : e2e_level_) worst = std::max(worst, l);
  const bool ready = !fault_now && !bus_off_ && worst <= p_.e2e_tolerance();
  // Engage on a rising edge of the enable bits themselves: the PU's frames (or heartbeat) coming back
  // after a timeout with enable still set is not a new request.
  if (requested && !prev_enable_bits_ && ready && !override_now) engaged_ = true;
  prev_enable_bits_ = enable_bits;

  ActuatorRequest act;
  act.steer = model_.state().steer;  // disengaged: the driver holds the wheel
  if (engaged_) act = req_;
  model_.step(act, dt);

  if (bus_off_) return out;
  const auto& rxm = p_.rx_messages();
  if (now >= next_status_) {
    // On the ECU's own grid, as a real ECU's cyclic messages: `now + period` slipped by each step's
    // lateness (the 1 ms tick), and the mock sent at 97 Hz instead of 100 (rig chaos' isolation saw it).
    // Far behind (a stalled process), it starts a new grid rather than bursting to catch up.
    next_status_ += p_.timing().tx_period_ns;
    if (next_status_ <= now) next_status_ = now + p_.timing().tx_period_ns;
    const auto& s = model_.state();
    for (std::size_t i = 0; i < rxm.size(); ++i) {
      if (rxm[i].role == "status") {
        if (fault_active(FaultKind::kNoStatus, t_s) != nullptr) continue;
        emit(i, {{"ready", ready ? 1 : 0}, {"engaged", engaged_ ? 1 : 0}, {"override", override_now ? 1 : 0},
                 {"fault", fault_now ? 1 : 0}, {"fault_code", fault_now ? 1 : 0}},
             t_s, now, out);
      } else if (rxm[i].role == "feedback") {
        emit(i, {{"speed", s.speed}, {"steering_angle", s.steer}, {"yaw_rate", s.yaw_rate},
                 {"gear", static_cast<double>(s.gear)}},
             t_s, now, out);
      } else if (rxm[i].role == "wheels" && now >= next_wheels_) {
        next_wheels_ += 2 * p_.timing().tx_period_ns;
        if (next_wheels_ <= now) next_wheels_ = now + 2 * p_.timing().tx_period_ns;
        double w[4];
        model_.wheel_speeds(w);
        emit(i, {{"fl", w[0]}, {"fr", w[1]}, {"rl", w[2]}, {"rr", w[3]}}, t_s, now, out);
      }
    }
  }
  return out;
}

}  // namespace sensor_rig::dbw::mock
