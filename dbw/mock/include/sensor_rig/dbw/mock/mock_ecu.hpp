#pragma once
// The mock Paravan ECU: speaks a Protocol (normally the reference one) from the ECU side. It checks
// the PU's counters/CRCs and timeouts as a real ECU would, actuates a VehicleModel only while enabled
// by valid, fresh commands, and injects faults. Pure: frames in, frames out, time as arguments.
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"
#include "sensor_rig/dbw/can/frame.hpp"
#include "sensor_rig/dbw/mock/vehicle_model.hpp"
#include "sensor_rig/dbw/safety/e2e.hpp"

namespace sensor_rig::dbw::mock {

enum class FaultKind : std::uint8_t { kFrameLoss, kBadCrc, kStuckCounter, kDriverOverride, kEcuFault, kBusOff, kNoStatus };

// "name[=value][@start_s][+duration_s]": loss=0.2, bad-crc@2, stuck-counter@2+1, override@3+0.5,
// ecu-fault@4, bus-off@5+0.3, no-status@6+0.3 (the status message, the ECU's heartbeat, stops; the
// rest goes on). Without a start: from the beginning; without duration: until the end.
struct Fault {
  FaultKind kind = FaultKind::kFrameLoss;
  double value = 1.0;  // loss probability
  double start_s = 0.0;
  double duration_s = -1.0;
  std::uint64_t id = 0;  // the fault plan's event id (rig chaos), 0 = a --fault of the command line
  [[nodiscard]] bool active(double t_s) const noexcept {
    return t_s >= start_s && (duration_s < 0.0 || t_s < start_s + duration_s);
  }
};
Fault parse_fault(const std::string& spec);  // throws std::invalid_argument

struct EcuCounters {
  std::uint64_t rx_frames = 0;
  std::uint64_t rx_e2e_errors = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t tx_dropped = 0;  // injected loss
  std::uint64_t pu_timeouts = 0;
};

// One frame the ECU made, and what became of it: the truth record's unit (a feedback frame is one
// sample of /vehicle/state). `on_bus`: handed to the bus as made (or with the fault's change).
struct EmittedFrame {
  std::string_view role;  // status, feedback, wheels
  enum class Fate : std::uint8_t { kSent, kDropped, kBadCrc, kRepeatedCounter } fate = Fate::kSent;
  std::uint64_t fault = 0;  // the fault that decided the fate (its plan id), 0 = none
  Nanos now = 0;            // the step's time (monotonic)
};

class MockEcu {
 public:
  MockEcu(const Protocol& protocol, std::vector<Fault> faults, std::uint64_t seed = 1);

  // A frame from the bus at time `now` (monotonic).
  void on_frame(const can::Frame& f, Nanos now);
  // Advances the model to `now`; returns the frames to put on the bus (status, feedback, wheels,
  // or bus-off/restart error frames).
  std::vector<can::Frame> step(Nanos now);

  // Called for every frame step() makes, before it is returned (the truth record of rig chaos).
  void set_observer(std::function<void(const EmittedFrame&)> f) { observer_ = std::move(f); }

  [[nodiscard]] bool engaged() const noexcept { return engaged_; }
  [[nodiscard]] bool bus_off() const noexcept { return bus_off_; }
  [[nodiscard]] const VehicleModel& model() const noexcept { return model_; }
  [[nodiscard]] const EcuCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const std::string& last_disengage() const noexcept { return last_disengage_; }

 private:
  const Fault* fault_active(FaultKind k, double t_s) const noexcept;
  void disengage(const std::string& why);
  void emit(std::size_t index, std::initializer_list<std::pair<std::string_view, double>> values, double t_s, Nanos now,
            std::vector<can::Frame>& out);

  const Protocol& p_;
  std::vector<Fault> faults_;
  std::mt19937_64 rng_;
  VehicleModel model_;
  std::vector<safety::E2eChecker> checkers_;  // per tx (PU->ECU) message
  std::vector<safety::E2eSender> senders_;    // per rx (ECU->PU) message
  std::vector<int> last_counter_;             // per rx message: the counter of its last frame, -1 none
  std::function<void(const EmittedFrame&)> observer_;
  std::vector<int> e2e_level_;
  Nanos start_ = -1;
  Nanos last_step_ = -1;
  Nanos last_steer_ = -1, last_long_ = -1, last_heartbeat_ = -1;
  Nanos next_status_ = 0, next_wheels_ = 0;
  bool steer_enable_ = false, long_enable_ = false, engaged_ = false;
  bool prev_enable_bits_ = false;
  bool bus_off_ = false;
  ActuatorRequest req_{};
  EcuCounters counters_{};
  std::string last_disengage_;
};

}  // namespace sensor_rig::dbw::mock
