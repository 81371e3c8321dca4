#include "mock_faults.hpp"

#include <signal.h>
#include <unistd.h>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig {

MockFaults::MockFaults(const faults::Plan& plan, std::vector<MockProcess>& mocks, std::mutex& mutex, const std::string& truth_path)
    : epoch_mono_(plan.epoch_mono_ns),
      // The plan's epoch on the vehicle clock, as of now (the truth's times are vehicle time).
      epoch_vehicle_(vehicle_now_ns() + (plan.epoch_mono_ns - monotonic_now_ns())),
      mocks_(mocks),
      mutex_(mutex),
      truth_(truth_path, truth::Header{"host", "host", "rig up", "", "", "CLOCK_REALTIME"}) {
  for (const auto& e : plan.events)
    if (e.kind == "host.kill_mock" || e.kind == "host.stall_mock") events_.push_back(e);
  thread_ = std::thread([this] { run(); });
}

MockFaults::~MockFaults() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

bool MockFaults::sleep_until(Nanos mono) {
  while (!stop_ && monotonic_now_ns() < mono) ::usleep(2'000);
  return !stop_;
}

void MockFaults::run() {
  for (const auto& e : events_) {
    if (!sleep_until(epoch_mono_ + static_cast<Nanos>(e.at_s * 1e9))) return;
    apply(e);
  }
  // This thread stays until the rig stops: the mocks it restarted have it as their parent thread, and
  // PR_SET_PDEATHSIG (ChildProcess) sends them SIGTERM when that thread ends. Returning here stopped
  // every restarted mock after the campaign's last kill or stall (the mock ECU left the bus for good).
  while (!stop_) ::usleep(20'000);
}

void MockFaults::apply(const faults::FaultEvent& e) {
  const Nanos at = vehicle_now_ns();
  MockProcess* m = nullptr;
  for (auto& p : mocks_)
    if (p.device == e.device) m = &p;
  if (m == nullptr) {
    log::warn("chaos", e.kind + ": no mock process plays device '" + e.device + "'");
    return;
  }
  if (e.kind == "host.stall_mock") {
    const Nanos pause = static_cast<Nanos>(e.number("ms", 300) * 1e6);
    {
      std::lock_guard lock(mutex_);
      m->child.signal(SIGSTOP);
    }
    truth_.fault({e.id, e.kind, at, at + pause, -1, e.device + " stopped " + std::to_string(pause / 1'000'000) + " ms"});
    truth_.flush();
    sleep_until(monotonic_now_ns() + pause);
    std::lock_guard lock(mutex_);
    m->child.signal(SIGCONT);  // also when stopping: never leave a stopped process behind
    return;
  }
  const Nanos restart = static_cast<Nanos>(e.number("restart_s", 1) * 1e9);
  {
    std::lock_guard lock(mutex_);
    m->child.signal(SIGKILL);
    m->child.wait_exit(2000);
  }
  truth_.fault({e.id, e.kind, at, at + restart, -1, e.device + " killed, restarted after " + std::to_string(restart / 1'000'000) + " ms"});
  truth_.flush();
  log::info("chaos", "host.kill_mock: killed the mock of " + e.device);
  if (!sleep_until(monotonic_now_ns() + restart)) return;
  std::lock_guard lock(mutex_);
  m->child = ChildProcess(m->argv, m->options);
  log::info("chaos", "host.kill_mock: restarted the mock of " + e.device + ": pid " + std::to_string(m->child.pid()));
}

}  // namespace sensor_rig::rig
