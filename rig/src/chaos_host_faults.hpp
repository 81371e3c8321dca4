#pragma once
// The host's faults under `rig chaos` that are not a mock's (rig up kills and stops its mocks
// itself): host.cpu_hog (busy threads at normal priority, as a runaway process of the PU would be)
// and host.clock_step (CLOCK_REALTIME stepped, and stepped back when the fault ends), begun at the
// plan's times from a thread of their own, each recorded in the host's truth record as it begins.
// host.network_delay: netem on lo (network_delay.hpp) when the plan gives it to the host (device
// "lo"), else recorded here with its parameters while the LIDAR mocks hold their datagrams (± the
// jitter, in order).
#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "clock_step.hpp"
#include "network_delay.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::rig::chaos {

class HostFaults {
 public:
  // `loopback_ports`: the UDP ports host.network_delay shapes on lo when its event is the host's own
  // (device "lo": netem available, chaos_run.cpp); other network delays are the LIDAR mocks'.
  HostFaults(std::vector<faults::FaultEvent> events, Nanos epoch_mono, const std::string& truth_path,
             std::vector<int> loopback_ports = {});
  ~HostFaults() { stop(); }
  HostFaults(const HostFaults&) = delete;
  HostFaults& operator=(const HostFaults&) = delete;

  void start();
  void stop();  // every hog ended, every step undone, also when stopped early

 private:
  struct Step {
    Nanos undo_mono;
    std::unique_ptr<ClockStep> step;
  };
  struct Delay {
    Nanos undo_mono;
    std::unique_ptr<LoopbackDelay> delay;
  };
  [[nodiscard]] Nanos at_mono(double s) const { return epoch_mono_ + static_cast<Nanos>(s * 1e9); }
  void run();
  void begin(const faults::FaultEvent& e);

  std::vector<faults::FaultEvent> events_;
  Nanos epoch_mono_;
  truth::Writer truth_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::vector<std::thread> hogs_;
  std::vector<Step> steps_;
  std::vector<int> loopback_ports_;
  std::vector<Delay> delays_;
};

}  // namespace sensor_rig::rig::chaos
