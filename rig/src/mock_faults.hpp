#pragma once
// The host's faults on mock processes under `rig chaos` (host.kill_mock, host.stall_mock): `rig up`
// owns its mocks, so it kills (SIGKILL) and restarts, or stops (SIGSTOP) and continues them at the
// plan's times, and records each in the truth record DIR/truth/host_mocks.jsonl.
#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::rig {

struct MockProcess {
  std::string device;  // the config name of the device it plays ("paravan" for the mock ECU)
  std::vector<std::string> argv;
  ChildOptions options;
  ChildProcess child;
};

class MockFaults {
 public:
  // `mocks` and `mutex` outlive this; every access to `mocks` elsewhere holds `mutex`.
  MockFaults(const faults::Plan& plan, std::vector<MockProcess>& mocks, std::mutex& mutex, const std::string& truth_path);
  ~MockFaults();
  MockFaults(const MockFaults&) = delete;
  MockFaults& operator=(const MockFaults&) = delete;

 private:
  // One signal at its time: a kill's restart or a stall's continue is an action of its own, so that
  // an event never waits for another's (a stall 0.5 s into another mock's 1 s restart came 0.5 s
  // late when each event slept through its own span).
  struct Action {
    Nanos mono = 0;
    enum class Kind : std::uint8_t { kKill, kRestart, kStop, kContinue } kind = Kind::kKill;
    const faults::FaultEvent* event = nullptr;
  };
  void run();
  bool sleep_until(Nanos mono);  // false when stopping
  void apply(const Action& a);
  MockProcess* mock_of(const faults::FaultEvent& e);
  // The mock's options for a restart: with the host clock step in force, if any.
  [[nodiscard]] ChildOptions restart_options(const MockProcess& m) const;

  std::vector<faults::FaultEvent> events_;
  std::vector<Action> actions_;  // by time
  Nanos epoch_mono_;
  Nanos epoch_vehicle_;  // the plan's epoch on CLOCK_REALTIME before any step: the steps since are measured by it
  std::vector<MockProcess>& mocks_;
  std::mutex& mutex_;
  truth::Writer truth_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sensor_rig::rig
