#pragma once
// The bridge without DDS: commands -> safety -> encoder (DBC signals, counter, CRC) -> frames, and
// ECU frames -> E2E check -> status/feedback -> safety. No I/O; time is passed in (vehicle time).
#include <array>
#include <cstdint>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"
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

enum class RxKind : std::uint8_t { other, status, feedback, wheels, error_frame, e2e_error };

struct BridgeCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_refused = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t encode_errors = 0;
};

class BridgeCore {
 public:
  explicit BridgeCore(const Protocol& p);

  void on_command(const safety::Command& c, Nanos now) { safety_.on_command(c, now); }
  RxKind on_frame(const can::RxFrame& rx, Nanos now);
  void on_bus_state(can::BusState s, Nanos now) { safety_.on_bus_state(s == can::BusState::bus_off, now); }
  // Appends the frames to transmit now: command (or neutral/disengage) messages + heartbeat.
  void frames(Nanos now, std::vector<can::Frame>& out);

  [[nodiscard]] safety::SafetyCore& safety() noexcept { return safety_; }
  [[nodiscard]] const safety::EcuStatus& ecu() const noexcept { return ecu_; }
  [[nodiscard]] const VehicleFeedback& feedback() const noexcept { return fb_; }
  [[nodiscard]] BridgeCounters& counters() noexcept { return counters_; }
  [[nodiscard]] const Protocol& protocol() const noexcept { return p_; }

 private:
  // What a tx message carries, resolved once: the hot path does no role-name lookups.
  enum class TxField : std::uint8_t { enable, state, mode, angle, torque, gear, throttle, brake, accel, count };
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
  safety::EcuStatus ecu_{};
  VehicleFeedback fb_{};
  BridgeCounters counters_{};
};

safety::SafetyConfig safety_config(const Protocol& p);

}  // namespace sensor_rig::dbw
