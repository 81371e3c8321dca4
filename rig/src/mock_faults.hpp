#pragma once
// The host's faults on mock processes under `rig chaos` (host.kill_mock, host.stall_mock): `rig up`
// owns its mocks, so it kills (SIGKILL) and restarts, or stops (SIGSTOP) and continues them at the
// plan's times, and records each in the truth record DIR/truth/host_mocks.jsonl. A kill's line is
// written when its mock is back: its "until" is the real restart, which the judge measures recovery
// from (a restart 488 ms late, plus the mock's own start, was charged to the rig: seed 25, right).
#include <atomic>
#include <cstdint>
#include <map>
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
  // Vehicle time on the plan's clock: CLOCK_MONOTONIC from the plan's epoch, so that a host clock
  // step in force does not move the truth's times (the mocks take it off theirs alike).
  [[nodiscard]] Nanos plan_vehicle_now() const { return epoch_vehicle_ + (monotonic_now_ns() - epoch_mono_); }
  // The kill's truth line, once its mock is back (or the rig stops first): `until` is then.
  void record_kill(const faults::FaultEvent& e, Nanos until, const std::string& how);

  std::vector<faults::FaultEvent> events_;
  std::vector<Action> actions_;  // by time
  Nanos epoch_mono_;
  Nanos epoch_vehicle_;  // the plan's epoch on CLOCK_REALTIME before any step: the steps since are measured by it
  std::vector<MockProcess>& mocks_;
  std::mutex& mutex_;
  truth::Writer truth_;
  struct Killed {
    Nanos at = 0;      // the SIGKILL (plan vehicle time)
    Nanos planned = 0;  // its restart as planned
    std::string what;  // "right killed", "right not running (...)"
  };
  std::map<std::uint64_t, Killed> killed_;          // by event id: kills whose line waits for the restart
  std::map<std::string, Nanos> last_restart_;       // by device: when its mock was last started again
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sensor_rig::rig
