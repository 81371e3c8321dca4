#pragma once
// The safety state machine between validated DDS commands and the CAN encoder. Pure: every input
// carries the time, nothing here reads a clock or does I/O, nothing allocates after construction.
//
// Time: `now` is the bridge's monotonic receive/tick time; every timeout runs on it. A command's
// own stamp (vehicle time) is only checked for plausibility against `vehicle_now`, so a step of the
// vehicle clock in either direction never keeps a command alive beyond its timeout.
//
// Writers: sequence, stamp order and the enable edge are tracked per writer (DDS publication
// handle). Engage only on a rising edge of one writer's `enable` (seen false, then true, since the
// start and since the last disengage or refusal) in a valid command while the ECU's status is fresh,
// it is ready, reports no driver override and no fault, E2E errors are within tolerance and the bus
// is not off. The engaging writer owns the engagement: only its commands drive the actuators; any
// writer's `enable=false` disengages at once (whatever its seq or stamp). Disengage also on: command
// older than its timeout (from receipt), ECU status timeout, E2E errors beyond tolerance, driver
// override, ECU fault or not ready, a rejected command, bus-off, shutdown. Rate limits start from
// the measured actuator state on engagement. Every transition and refusal is an Event.
#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/safety/command.hpp"
#include "sensor_rig/dbw/safety/limits.hpp"

namespace sensor_rig::dbw::safety {

enum class State : std::uint8_t { kDisengaged, kEngaged };

enum class Reason : std::uint8_t {
  kNone,
  kEnabled,  // engaged on an enable edge
  kEnableReleased,
  kCommandTimeout,
  kEcuTimeout,
  kE2eErrors,
  kDriverOverride,
  kEcuFault,
  kEcuNotReady,
  kInvalidCommand,  // NaN/inf or a rejected limit violation
  kBusOff,
  kNoCommand,  // engage refused: no fresh command
  kNotOwner,   // command ignored: another writer owns the engagement
  kShutdown,   // the bridge is stopping
};
[[nodiscard]] std::string_view to_string(State s) noexcept;
[[nodiscard]] std::string_view to_string(Reason r) noexcept;

struct SafetyConfig {
  Nanos command_timeout_ns = 100'000'000;
  Nanos ecu_timeout_ns = 100'000'000;
  Nanos max_future_ns = 20'000'000;  // a command stamped further ahead than this is implausible
  int e2e_tolerance = 3;             // bad frames (net of good ones) tolerated before disengaging
  // Rate limits use the shorter of the stamp interval and the receive interval plus this slack
  // (delivery jitter): neither a sender's stamps nor a burst of deliveries can widen a step.
  Nanos rate_rx_slack_ns = 2'000'000;
  VehicleLimits limits = kParavanRef;
};

// The E2E error level saturates here (AUTOSAR/opendbc): a long burst of bad frames is paid back by
// a bounded number of good ones.
[[nodiscard]] constexpr int e2e_level_max(const SafetyConfig& c) noexcept { return 2 * c.e2e_tolerance + 1; }

struct EcuStatus {
  bool ready = false;
  bool engaged = false;
  bool override = false;
  bool fault = false;
  std::uint8_t fault_code = 0;
};

enum class EventKind : std::uint8_t { kTransition, kEngageRefused, kLimit, kCommandIgnored, kFault };
[[nodiscard]] std::string_view to_string(EventKind k) noexcept;

struct Event {
  Nanos t = 0;  // the `now` of the call that caused it (monotonic)
  EventKind kind = EventKind::kTransition;
  State state = State::kDisengaged;  // state after the event
  Reason reason = Reason::kNone;
  Violation violation{};  // kind == limit
};

struct Decision {
  bool active = false;  // true: send `command`; false: send the neutral/disengage frame
  Command command{};
  State state = State::kDisengaged;
};

struct SafetyCounters {
  std::uint64_t commands = 0;
  std::uint64_t applied = 0;           // commands that became what the bus carries
  std::uint64_t ignored_stale = 0;     // stamp too old on arrival, or from the future
  std::uint64_t ignored_sequence = 0;  // seq not increasing (per writer)
  std::uint64_t ignored_stamp = 0;     // stamp not after the writer's previous one (would dodge rate limits)
  std::uint64_t ignored_writer = 0;    // from a writer that does not own the engagement
  std::uint64_t rejected = 0;
  std::uint64_t clamped = 0;
  std::uint64_t e2e_errors = 0;
  std::uint64_t engagements = 0;
  std::uint64_t disengagements = 0;
  std::uint64_t events_dropped = 0;    // event buffer full (nobody drained it)
};

// What the core remembers per writer.
struct WriterState {
  WriterId id = 0;
  bool used = false;
  bool valid = false;      // its last command passed the checks (a basis for rate intervals)
  bool armed = false;      // enable seen false since the start / the last disengage or refusal
  std::uint64_t last_seq = 0;
  Nanos last_stamp = 0;
  Nanos last_rx = 0;
};

class SafetyCore {
 public:
  static constexpr std::size_t kMaxWriters = 8;  // more: the least recently heard one is forgotten
  static constexpr std::size_t kMaxEvents = 64;

  explicit SafetyCore(const SafetyConfig& cfg);

  // `now`: monotonic receive time; `vehicle_now`: vehicle time at receipt (stamp plausibility).
  void on_command(const Command& cmd, Nanos now, Nanos vehicle_now);
  void on_ecu_status(const EcuStatus& st, Nanos now);
  void on_e2e(bool ok, Nanos now);  // one protected frame from the ECU checked
  void on_bus_state(bool bus_off, Nanos now);
  // The actuators as measured (ECU feedback): the start of the rate limits on engagement, and the
  // speed of the lateral-acceleration steering limit. NaN: that value was not measured (unchanged).
  void on_measured(double steering_angle, double speed_mps) noexcept;
  // Disengages for good (no engagement afterwards): the bridge is stopping.
  void shutdown(Nanos now);
  // Evaluates the timeouts at `now` and returns what to transmit.
  Decision tick(Nanos now);

  [[nodiscard]] State state() const noexcept { return state_; }
  [[nodiscard]] Reason reason() const noexcept { return reason_; }  // of the last transition
  [[nodiscard]] WriterId owner() const noexcept { return owner_; }
  [[nodiscard]] std::uint64_t transitions() const noexcept { return counters_.engagements + counters_.disengagements; }
  [[nodiscard]] const SafetyCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const SafetyConfig& config() const noexcept { return cfg_; }
  [[nodiscard]] int e2e_error_level() const noexcept { return e2e_level_; }
  [[nodiscard]] bool has_fresh_command(Nanos now) const noexcept;
  [[nodiscard]] bool ecu_fresh(Nanos now) const noexcept;
  // Events since the last clear_events(), oldest first (a fixed buffer: no allocation).
  [[nodiscard]] std::span<const Event> events() const noexcept { return {events_.data(), n_events_}; }
  void clear_events() noexcept { n_events_ = 0; }
  // events() then clear_events(), as a vector (tests and tools; allocates).
  std::vector<Event> take_events();

 private:
  void engage(WriterState& w, const Command& applied, Nanos now);
  void disengage(Reason r, Nanos now);
  void emit(Nanos now, EventKind k, Reason r, const Violation& v = {});
  [[nodiscard]] Reason engage_blocker(Nanos now) const noexcept;
  WriterState& writer(WriterId id) noexcept;
  void disarm_all() noexcept;

  SafetyConfig cfg_;
  LimitChecker checker_;
  State state_ = State::kDisengaged;
  Reason reason_ = Reason::kNone;
  Command latest_{};           // the owner's latest applied command
  WriterId owner_ = 0;
  Nanos last_cmd_rx_ = 0;      // monotonic receipt of `latest_`
  std::array<WriterState, kMaxWriters> writers_{};
  EcuStatus ecu_{};
  bool have_ecu_ = false;
  Nanos last_ecu_ = 0;
  int e2e_level_ = 0;
  bool bus_off_ = false;
  bool stopping_ = false;
  std::uint32_t reported_limits_ = 0;  // kinds of violation of the previous command (one bit each)
  double measured_steering_ = 0.0;
  double measured_speed_ = 0.0;
  SafetyCounters counters_{};
  std::array<Event, kMaxEvents> events_{};
  std::size_t n_events_ = 0;
};

}  // namespace sensor_rig::dbw::safety
