#pragma once
// When the bridge may put a frame set on the bus, whatever the command rate. A new command goes
// out at once unless the previous command-carrying set left less than 4/5 of a period ago (then it
// waits at most that long: a source at the bus rate with ~2 ms jitter is never held back, a 5 kHz
// publisher gets 125 sets/s instead of flooding a 500 kbit/s bus). Without new commands the set
// (command or neutral, heartbeat) repeats one period after the last one. A transition is never
// held back (the disengage is the safe frame; an engage needs an edge, itself rate-bound). Pure.
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::dbw {

class TxSchedule {
 public:
  explicit TxSchedule(Nanos period) noexcept : period_(period), spacing_(period * 4 / 5) {}

  [[nodiscard]] bool command_may_go(Nanos now) const noexcept { return !command_sent_ || now - last_command_ >= spacing_; }
  [[nodiscard]] bool periodic_due(Nanos now) const noexcept { return !sent_ || now - last_sent_ >= period_; }
  // A set went out at `now`; `carries_new_command`: it is the first to carry the latest command.
  void sent(Nanos now, bool carries_new_command) noexcept {
    last_sent_ = now;
    sent_ = true;
    if (carries_new_command) {
      last_command_ = now;
      command_sent_ = true;
    }
  }
  [[nodiscard]] Nanos period() const noexcept { return period_; }
  [[nodiscard]] Nanos command_spacing() const noexcept { return spacing_; }

 private:
  Nanos period_;
  Nanos spacing_;
  Nanos last_sent_ = 0;
  Nanos last_command_ = 0;
  bool sent_ = false;
  bool command_sent_ = false;
};

}  // namespace sensor_rig::dbw
