#include "host_time_node.hpp"

#include <sys/wait.h>

#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <thread>
#include <utility>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/timesync/host_clock.hpp"

namespace sensor_rig::rig {
namespace {

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct PmcRun {
  bool ran = false;  // false: not installed, not executable, or killed by the timeout
  std::string output;
  std::string why_not;
};

// coreutils `timeout` bounds a hung pmc (a ptp4l that stopped answering its socket).
PmcRun run_pmc(const std::string& program, int timeout_ms) {
  const std::string seconds = std::to_string(static_cast<double>(timeout_ms) / 1000.0);
  const std::string cmd = "timeout -k 1 " + seconds + " " + shell_quote(program) + " -u -b 0 'GET TIME_STATUS_NP' 2>&1";
  PmcRun r;
  FILE* f = ::popen(cmd.c_str(), "r");
  if (f == nullptr) {
    r.why_not = "cannot run pmc";
    return r;
  }
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0 && r.output.size() < 1 << 20) r.output.append(buf, n);
  const int status = ::pclose(f);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  if (code == 127 || code == 126) {
    r.why_not = "no linuxptp (" + program + " not found)";
  } else if (code == 124 || code >= 128) {
    r.why_not = "pmc did not answer within " + seconds + " s";
  } else {
    r.ran = true;
  }
  return r;
}

}  // namespace

std::string pmc_program(const std::string& fallback) {
  const char* env = std::getenv("RIG_PMC");
  return env != nullptr && *env != '\0' ? env : fallback;
}

struct HostTimeNode::Impl {
  HostTimeOptions opt;
  std::mutex mu;
  std::condition_variable wake;
  bool stopping = false;
  std::thread poller;
  timesync::HostSyncStatus sync;  // guarded by mu
  std::uint64_t polls = 0;        // guarded by mu
  timesync::RealtimeStepDetector steps;  // diagnostics loop only

  void poll_loop() {
    std::unique_lock lock(mu);
    while (!stopping) {
      lock.unlock();
      const PmcRun run = run_pmc(opt.pmc, opt.pmc_timeout_ms);
      auto status = timesync::host_sync_status(run.ran, run.output, opt.max_offset_ns);
      if (!run.ran) status.reason = run.why_not + ": free-running host clock";
      lock.lock();
      if (polls == 0 || status.state != sync.state)
        log::info("rig", std::string("host clock: ") + timesync::to_string(status.state) + " (" + status.reason + ")");
      sync = std::move(status);
      ++polls;
      wake.wait_for(lock, std::chrono::milliseconds(opt.poll_period_ms), [this] { return stopping; });
    }
  }
};

HostTimeNode::HostTimeNode(HostTimeOptions options) : impl_(std::make_unique<Impl>()) { impl_->opt = std::move(options); }

HostTimeNode::~HostTimeNode() { stop(); }

void HostTimeNode::start() {
  if (impl_->poller.joinable()) return;
  impl_->poller = std::thread([this] { impl_->poll_loop(); });
}

void HostTimeNode::stop() {
  {
    const std::lock_guard lock(impl_->mu);
    impl_->stopping = true;
  }
  impl_->wake.notify_all();
  if (impl_->poller.joinable()) impl_->poller.join();
}

void HostTimeNode::supervise(std::vector<dds::DriverStatus>& statuses) {
  auto& steps = impl_->steps;
  const std::uint64_t before = steps.steps();
  const auto now = clock_pair_now();
  steps.observe(now.vehicle_ns, now.monotonic_ns);
  if (steps.steps() != before)
    log::warn("rig", "host clock: CLOCK_REALTIME stepped by " + std::to_string(steps.last_step_ns()) +
                         " ns while running (stamps before and after differ by it)");

  dds::DriverStatus s;
  s.name = "rig/time";
  s.hardware_id = "CLOCK_REALTIME";
  {
    const std::lock_guard lock(impl_->mu);
    const auto& sync = impl_->sync;
    using timesync::HostSyncState;
    // Not synchronized is this host's normal state without PTP: a warning, not an error; a PTP
    // that answers and is off, or unreadable pmc output, is an error.
    s.level = impl_->polls == 0                                 ? dds::Level::kStale
              : sync.state == HostSyncState::kSynchronized      ? dds::Level::kOk
              : sync.state == HostSyncState::kNotSynchronized   ? dds::Level::kWarn
                                                                : dds::Level::kError;
    s.message = impl_->polls == 0 ? std::string("waiting for the first pmc poll") : sync.reason;
    s.add("ptp_state", impl_->polls == 0 ? std::string("unknown") : std::string(timesync::to_string(sync.state)));
    s.add_number("master_offset_ns", sync.master_offset_ns);
    s.add("grandmaster", sync.gm_identity);
    s.add_number("pmc_polls", impl_->polls);
  }
  s.add_number("realtime_steps", steps.steps());
  s.add_number("last_step_ns", steps.last_step_ns());
  s.add_number("total_step_ns", steps.total_step_ns());
  if (steps.steps() != 0 && s.level == dds::Level::kOk) s.level = dds::Level::kWarn;
  statuses.push_back(std::move(s));
}

}  // namespace sensor_rig::rig
