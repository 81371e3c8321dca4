#include "mock_faults.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig {

MockFaults::MockFaults(const faults::Plan& plan, std::vector<MockProcess>& mocks, std::mutex& mutex, const std::string& truth_path)
    : epoch_mono_(plan.epoch_mono_ns),
      // The plan's epoch on the vehicle clock, as of now (the truth's times are vehicle time).
      epoch_vehicle_(plan.epoch_mono_ns + clock_pair_now().vehicle_minus_monotonic()),
      mocks_(mocks),
      mutex_(mutex),
      truth_(truth_path, truth::Header{"host", "host", "rig up", "", "", "CLOCK_REALTIME"}) {
  for (const auto& e : plan.events)
    if (e.kind == "host.kill_mock" || e.kind == "host.stall_mock") events_.push_back(e);
  for (const auto& e : events_) {  // events_ is complete: its addresses hold
    const Nanos at = epoch_mono_ + static_cast<Nanos>(e.at_s * 1e9);
    if (e.kind == "host.kill_mock") {
      actions_.push_back({at, Action::Kind::kKill, &e});
      actions_.push_back({at + static_cast<Nanos>(e.number("restart_s", 1) * 1e9), Action::Kind::kRestart, &e});
    } else {
      actions_.push_back({at, Action::Kind::kStop, &e});
      actions_.push_back({at + static_cast<Nanos>(e.number("ms", 300) * 1e6), Action::Kind::kContinue, &e});
    }
  }
  std::stable_sort(actions_.begin(), actions_.end(), [](const Action& a, const Action& b) { return a.mono < b.mono; });
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
  std::size_t next = 0;
  for (; next < actions_.size() && sleep_until(actions_[next].mono); ++next) apply(actions_[next]);
  // Stopping: never leave a stopped process behind (a restart that is not due is not made).
  for (; next < actions_.size(); ++next)
    if (actions_[next].kind == Action::Kind::kContinue) apply(actions_[next]);
  {
    std::lock_guard lock(mutex_);
    for (const auto& e : events_)  // killed, not back before the rig stopped: recorded as planned
      if (const auto k = killed_.find(e.id); k != killed_.end()) record_kill(e, k->second.planned, "not restarted: the rig stopped first");
  }
  // This thread stays until the rig stops: the mocks it restarted have it as their parent thread, and
  // PR_SET_PDEATHSIG (ChildProcess) sends them SIGTERM when that thread ends. Returning here stopped
  // every restarted mock after the campaign's last kill or stall (the mock ECU left the bus for good).
  while (!stop_) ::usleep(20'000);
}

MockProcess* MockFaults::mock_of(const faults::FaultEvent& e) {
  for (auto& p : mocks_)
    if (p.device == e.device) return &p;
  return nullptr;
}

ChildOptions MockFaults::restart_options(const MockProcess& m) const {
  // CLOCK_REALTIME stepped since the plan began (host.clock_step in force, rig chaos): told to the
  // mock, which takes it off (mock_clock_pair_now). A millisecond of slack for the clock's own
  // drift over a campaign; the smallest step the plans draw is 2 ms.
  const Nanos step = clock_pair_now().vehicle_minus_monotonic() - (epoch_vehicle_ - epoch_mono_);
  ChildOptions o = m.options;
  if (step > kMs || step < -kMs) {
    o.env.push_back(std::string(kMockHostStepEnv) + "=" + std::to_string(step));
    log::info("chaos", "host.kill_mock: " + m.device + " restarted under a host clock step of " + std::to_string(step / kMs) + " ms");
  }
  return o;
}

void MockFaults::record_kill(const faults::FaultEvent& e, Nanos until, const std::string& how) {
  const auto k = killed_.find(e.id);
  if (k == killed_.end()) return;
  truth_.fault({e.id, e.kind, k->second.at, until, -1, k->second.what + ", " + how});
  truth_.flush();
  killed_.erase(k);
}

void MockFaults::apply(const Action& a) {
  const faults::FaultEvent& e = *a.event;
  const Nanos woke = monotonic_now_ns();
  std::lock_guard lock(mutex_);
  const Nanos locked = monotonic_now_ns(), at = plan_vehicle_now();
  MockProcess* m = mock_of(e);
  if (m == nullptr) {
    if (a.kind == Action::Kind::kKill || a.kind == Action::Kind::kStop)
      log::warn("chaos", e.kind + ": no mock process plays device '" + e.device + "'");
    return;
  }
  switch (a.kind) {
    case Action::Kind::kStop: {
      const Nanos pause = static_cast<Nanos>(e.number("ms", 300) * 1e6);
      const bool alive = m->child.running();  // not while a kill's restart is pending
      m->child.signal(SIGSTOP);
      truth_.fault({e.id, e.kind, at, at + pause, -1,
                    e.device + (alive ? " stopped " : " not running (killed): not stopped ") + std::to_string(pause / 1'000'000) + " ms"});
      truth_.flush();
      return;
    }
    case Action::Kind::kContinue: m->child.signal(SIGCONT); return;
    case Action::Kind::kKill: {
      const Nanos restart = static_cast<Nanos>(e.number("restart_s", 1) * 1e9);
      const bool alive = m->child.running();
      m->child.signal(SIGKILL);
      m->child.wait_exit(2000);
      killed_[e.id] = {at, at + restart, e.device + (alive ? " killed" : " not running (an earlier kill's restart pending)")};
      log::info("chaos", "host.kill_mock: killed the mock of " + e.device);
      return;
    }
    case Action::Kind::kRestart: {
      const auto k = killed_.find(e.id);
      const Nanos planned = k != killed_.end() ? k->second.planned : at;
      if (m->child.running()) {  // two kills of one mock overlapped: the first restart made it
        const auto r = last_restart_.find(e.device);
        record_kill(e, r != last_restart_.end() ? r->second : at, "back by an earlier kill's restart");
        return;
      }
      m->child = ChildProcess(m->argv, restart_options(*m));
      const Nanos started = monotonic_now_ns(), back = plan_vehicle_now();
      last_restart_[e.device] = back;
      const auto ms = [](Nanos ns) { return std::to_string(ns / 1'000'000); };
      record_kill(e, back, "restarted " + ms(back - planned) + " ms after its planned time");
      // Where a late restart's time went: this thread's wake-up, the mocks' lock, the child's start.
      const std::string timing = "woke " + ms(woke - a.mono) + " ms late, lock " + ms(locked - woke) + " ms, start " + ms(started - locked) + " ms";
      const std::string line = "host.kill_mock: restarted the mock of " + e.device + ": pid " + std::to_string(m->child.pid()) + " (" + timing + ")";
      if (back - planned > 50 * kMs)
        log::warn("chaos", line);
      else
        log::info("chaos", line);
      return;
    }
  }
}

}  // namespace sensor_rig::rig
