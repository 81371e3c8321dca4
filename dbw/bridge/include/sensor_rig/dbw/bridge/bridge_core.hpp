#pragma once
// The bridge without DDS: commands -> safety -> encoder (DBC signals, counter, CRC) -> frames, and
// ECU frames -> E2E check -> status/feedback -> safety, and when to transmit (TxSchedule). No I/O;
// time is passed in: `now` is the bridge's monotonic clock, `vehicle_now` vehicle time.
#include <array>
#include <cstdint>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/frame_loss_counter.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"
#include "sensor_rig/dbw/bridge/tx_schedule.hpp"
#include "sensor_rig/dbw/can/transport.hpp"
#include "sensor_rig/dbw/safety/e2e.hpp"
#include "sensor_rig/dbw/safety/safety_core.hpp"

namespace sensor_rig::dbw {

struct VehicleFeedback {
  Nanos stamp = 0;  // CAN receive time
  double speed = 0.0;
  double steering_angle = 0.0;
  double yaw_rate = 0.0;
  int gear = 0;
  double wheels[4] = {0, 0, 0, 0};
};

enum class RxKind : std::uint8_t { kOther, kStatus, kFeedback, kWheels, kErrorFrame, kE2eError };

struct BridgeCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_refused = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t encode_errors = 0;
  std::uint64_t commands_deferred = 0;  // changed commands held for the bus schedule
  std::uint64_t status_frames = 0;      // good frames that refreshed the ECU status (its heartbeat),
                                        // also one that carries feedback or wheels (RxKind says those)
};

class BridgeCore {
 public:
  explicit BridgeCore(const Protocol& p);

  // True when the command changed what goes on the bus (applied, or a transition).
  bool on_command(const safety::Command& c, Nanos now, Nanos vehicle_now);
  RxKind on_frame(const can::RxFrame& rx, Nanos now);
  void on_bus_state(can::BusState s, Nanos now) { safety_.on_bus_state(s == can::BusState::kBusOff, now); }
  // Whether to transmit a frame set now: a transition not yet on the bus (at once, in the same tick
  // as its cause), a new command within the bus schedule (a held one goes at the first tick that
  // allows it), or the periodic repeat. Evaluates the timeouts first. `command_changed`: the caller
  // just handed a command that changed the output (only counted when held back).
  [[nodiscard]] bool transmit_due(Nanos now, bool command_changed);
  // Appends the frames to transmit now: command (or neutral/disengage) messages + heartbeat; the
  // caller puts them on the bus (the schedule counts them as sent).
  void frames(Nanos now, std::vector<can::Frame>& out);

  [[nodiscard]] safety::SafetyCore& safety() noexcept { return safety_; }
  [[nodiscard]] const safety::EcuStatus& ecu() const noexcept { return ecu_; }
  [[nodiscard]] const VehicleFeedback& feedback() const noexcept { return fb_; }
  [[nodiscard]] BridgeCounters& counters() noexcept { return counters_; }
  [[nodiscard]] const Protocol& protocol() const noexcept { return p_; }
  // Feedback frames (the messages /vehicle/state is made of) the ECU sent and the bridge did not hand
  // on: lost on the bus, refused by the E2E check, or not delivered by the caller (FrameLossCounter).
  [[nodiscard]] std::uint64_t feedback_lost() const noexcept;
  [[nodiscard]] std::uint64_t feedback_gaps_unknown() const noexcept;
  // The caller could not hand a feedback frame on (its queue was full, the write failed).
  void feedback_not_delivered() noexcept { ++feedback_not_delivered_; }

 private:
  // What a tx message carries, resolved once: the hot path does no role-name lookups.
  enum class TxField : std::uint8_t {
    kEnable,
    kState,
    kMode,
    kAngle,
    kTorque,
    kGear,
    kThrottle,
    kBrake,
    kAccel,
    kCount
  };
  struct TxBinding {
    const dbc::Signal* signal;
    TxField field;
    double scale;
  };

  const Protocol& p_;
  safety::SafetyCore safety_;
  std::vector<std::vector<TxBinding>> tx_bindings_;  // per tx message
  std::vector<safety::E2eSender> senders_;   // per tx message
  std::vector<safety::E2eChecker> checkers_; // per rx message
  std::vector<FrameLossCounter> loss_;       // per rx message
  std::vector<bool> feeds_state_;            // per rx message: carries feedback (/vehicle/state)
  std::uint64_t feedback_not_delivered_ = 0;
  safety::EcuStatus ecu_{};
  VehicleFeedback fb_{};
  BridgeCounters counters_{};
  TxSchedule schedule_;
  std::uint64_t transitions_sent_ = 0;  // safety transitions already reflected on the bus
  std::uint64_t applied_sent_ = 0;      // applied commands already on the bus
};

safety::SafetyConfig safety_config(const Protocol& p);

}  // namespace sensor_rig::dbw
