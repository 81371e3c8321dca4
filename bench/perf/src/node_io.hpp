#pragma once
// The node's side of the runner protocol (see node.hpp): stdout READY, stdin START/STOP.
#include <atomic>
#include <optional>
#include <string>
#include <thread>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::bench::perf {

void announce_ready();
// Blocks until "START <t0>" (returns t0) or EOF/garbage/STOP (nullopt).
std::optional<Nanos> wait_for_start();

// Watches stdin for "STOP" or EOF in a thread and then calls `on_stop` once.
class StopWatcher {
 public:
  template <class F>
  explicit StopWatcher(F on_stop)
      : thread_([this, on_stop] {
          watch();
          stopped_.store(true);
          on_stop();
        }) {}
  ~StopWatcher() {
    if (thread_.joinable()) thread_.detach();  // blocked in read(); process exit ends it
  }
  StopWatcher(const StopWatcher&) = delete;
  StopWatcher& operator=(const StopWatcher&) = delete;
  [[nodiscard]] bool stopped() const noexcept { return stopped_.load(); }

 private:
  static void watch();
  std::atomic<bool> stopped_{false};
  std::thread thread_;
};

}  // namespace sensor_rig::bench::perf
