#pragma once
// The safety state machine between validated DDS commands and the CAN encoder. Pure: every input
// carries the time (`now`, vehicle time); nothing here reads a clock or does I/O.
//
// Engage only on a rising edge of `enable` in a fresh, valid command while the ECU's status is
// fresh, it is ready, reports no driver override and no fault, E2E errors are within tolerance and
// the bus is not off. An edge that cannot engage is consumed (reported as engage_refused): the
// operator must release and re-enable. Disengage on: enable released, command older than its timeout,
// ECU status timeout, E2E (counter/CRC) errors beyond tolerance, driver override, ECU fault or not
// ready, a rejected (out-of-range with action reject, NaN/inf) command, bus-off. Every transition and
// refusal is an Event with its reason. Commands whose seq or stamp does not advance are ignored;
// rate limits are checked against min(stamp interval, receive interval + slack). tick() says what to put on the bus: the latest fresh command,
// or the protocol's neutral/disengage frame — never a stale command.
#include <cstdint>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/safety/command.hpp"
#include "sensor_rig/dbw/safety/limits.hpp"

namespace sensor_rig::dbw::safety {

enum class State : std::uint8_t { disengaged, engaged };

enum class Reason : std::uint8_t {
  none,
  enabled,            // engaged on an enable edge
  enable_released,
  command_timeout,
  ecu_timeout,
  e2e_errors,
  driver_override,
  ecu_fault,
  ecu_not_ready,
  invalid_command,    // NaN/inf or a rejected limit violation
  bus_off,
  no_command,         // engage refused: no fresh command
};
[[nodiscard]] std::string_view to_string(State s) noexcept;
[[nodiscard]] std::string_view to_string(Reason r) noexcept;

struct SafetyConfig {
  Nanos command_timeout_ns = 100'000'000;
  Nanos ecu_timeout_ns = 100'000'000;
  Nanos max_future_ns = 20'000'000;  // a command stamped further ahead than this is invalid
  int e2e_tolerance = 3;             // bad frames (net of good ones) tolerated before disengaging
  // Rate limits use the shorter of the stamp interval and the receive interval plus this slack
  // (delivery jitter): neither a sender's stamps nor a burst of deliveries can widen a step.
  Nanos rate_rx_slack_ns = 2'000'000;
  VehicleLimits limits = kParavanRef;
};

struct EcuStatus {
  bool ready = false;
  bool engaged = false;
  bool override = false;
  bool fault = false;
  std::uint8_t fault_code = 0;
};

enum class EventKind : std::uint8_t { transition, engage_refused, limit, command_ignored, fault };
[[nodiscard]] std::string_view to_string(EventKind k) noexcept;

struct Event {
  Nanos t = 0;
  EventKind kind = EventKind::transition;
  State state = State::disengaged;  // state after the event
  Reason reason = Reason::none;
  Violation violation{};  // kind == limit
};

struct Decision {
  bool active = false;  // true: send `command`; false: send the neutral/disengage frame
  Command command{};
  State state = State::disengaged;
};

struct SafetyCounters {
  std::uint64_t commands = 0;
  std::uint64_t ignored_stale = 0;     // too old on arrival, or from the future
  std::uint64_t ignored_sequence = 0;  // seq not increasing
  std::uint64_t ignored_stamp = 0;     // stamp not after the previous command's (would dodge rate limits)
  std::uint64_t rejected = 0;
  std::uint64_t clamped = 0;
  std::uint64_t e2e_errors = 0;
  std::uint64_t engagements = 0;
  std::uint64_t disengagements = 0;
};

class SafetyCore {
 public:
  explicit SafetyCore(const SafetyConfig& cfg);

  void on_command(const Command& cmd, Nanos now);
  void on_ecu_status(const EcuStatus& st, Nanos now);
  void on_e2e(bool ok, Nanos now);  // one protected frame from the ECU checked
  void on_bus_state(bool bus_off, Nanos now);
  // Evaluates the timeouts at `now` and returns what to transmit.
  Decision tick(Nanos now);

  [[nodiscard]] State state() const noexcept { return state_; }
  [[nodiscard]] Reason reason() const noexcept { return reason_; }  // of the last transition
  [[nodiscard]] const SafetyCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const SafetyConfig& config() const noexcept { return cfg_; }
  [[nodiscard]] int e2e_error_level() const noexcept { return e2e_level_; }
  [[nodiscard]] bool has_fresh_command(Nanos now) const noexcept;
  [[nodiscard]] bool ecu_fresh(Nanos now) const noexcept;
  // Events since the last call, oldest first.
  std::vector<Event> take_events();

 private:
  void engage(Nanos now);
  void disengage(Reason r, Nanos now);
  void emit(Nanos now, EventKind k, Reason r, const Violation& v = {});
  [[nodiscard]] Reason engage_blocker(Nanos now) const noexcept;

  SafetyConfig cfg_;
  LimitChecker checker_;
  State state_ = State::disengaged;
  Reason reason_ = Reason::none;
  Command latest_{};
  bool have_cmd_ = false;
  bool cmd_valid_ = false;
  Nanos last_cmd_stamp_ = 0;   // of the latest valid command
  Nanos last_cmd_rx_ = 0;      // `now` when it arrived
  Nanos last_stamp_seen_ = 0;  // of the latest command not ignored (valid or rejected)
  std::uint64_t last_seq_ = 0;
  bool prev_enable_ = false;
  EcuStatus ecu_{};
  bool have_ecu_ = false;
  Nanos last_ecu_ = 0;
  int e2e_level_ = 0;
  bool bus_off_ = false;
  bool limit_reported_ = false;
  SafetyCounters counters_{};
  std::vector<Event> events_;
};

}  // namespace sensor_rig::dbw::safety
