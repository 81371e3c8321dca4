#pragma once
// Where a reader starts counting a topic's announced samples: the monitor and the recorder count a
// sample announced on /rig/stamps as missed only if it was published after their reader of its data
// matched (before, it was never theirs to receive).
#include <limits>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::rig {

struct CountingGate {
  Nanos since = std::numeric_limits<Nanos>::max();  // vehicle ns: the reader matched (plus a margin)

  // The first announcement published at or after `since` opens the gate for good: every later one
  // counts whatever its publish time says. A host clock stepped back by more than the time since the
  // reader matched puts later publish times before `since`, and the monitor then ignored every
  // stamp published during the step (a -37 s step at 5 s: 50 scans of each LIDAR "neither
  // published nor counted lost", the monitor "received 126 of 175").
  bool admits(Nanos publish_ns) noexcept {
    if (!open_ && publish_ns >= since) open_ = true;
    return open_;
  }
  [[nodiscard]] bool open() const noexcept { return open_; }

 private:
  bool open_ = false;
};

}  // namespace sensor_rig::rig
