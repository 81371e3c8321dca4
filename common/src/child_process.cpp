#include "sensor_rig/common/child_process.hpp"

#include <sched.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <system_error>
#include <utility>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig {

ChildProcess::ChildProcess(std::vector<std::string> argv, int rt_priority) {
  if (argv.empty()) throw std::invalid_argument("ChildProcess: empty argv");
  name_ = argv[0];
  for (std::size_t i = 1; i < argv.size() && i < 3; ++i) name_ += " " + argv[i];
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::system_error(errno, std::generic_category(), "fork");
  if (pid == 0) {
    // Default signal dispositions in the child; its own shutdown handlers are installed by it.
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    // If this process dies without stopping its children (SIGKILL, crash), they get SIGTERM:
    // no orphaned mock device keeps a port or a bus socket.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(126);  // the parent died between fork and prctl
    if (rt_priority > 0) {
      sched_param sp{};
      sp.sched_priority = rt_priority;
      ::sched_setscheduler(0, SCHED_FIFO, &sp);  // kept across exec; refused without privilege: fine
    }
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  pid_ = pid;
}

ChildProcess::ChildProcess(ChildProcess&& o) noexcept
    : pid_(std::exchange(o.pid_, -1)), status_(o.status_), name_(std::move(o.name_)) {}

ChildProcess& ChildProcess::operator=(ChildProcess&& o) noexcept {
  if (this != &o) {
    if (pid_ > 0) stop();
    pid_ = std::exchange(o.pid_, -1);
    status_ = o.status_;
    name_ = std::move(o.name_);
  }
  return *this;
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0) stop();
}

bool ChildProcess::running() {
  if (pid_ <= 0) return false;
  int st = 0;
  const pid_t r = ::waitpid(pid_, &st, WNOHANG);
  if (r == 0) return true;
  if (r == pid_) status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  pid_ = -1;
  return false;
}

int ChildProcess::stop(int grace_ms) {
  if (!running()) return status_;
  ::kill(pid_, SIGTERM);
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(grace_ms) * 1'000'000;
  while (monotonic_now_ns() < deadline) {
    if (!running()) return status_;
    ::usleep(10'000);
  }
  ::kill(pid_, SIGKILL);
  int st = 0;
  ::waitpid(pid_, &st, 0);
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  pid_ = -1;
  return status_;
}

std::string self_executable() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) throw std::system_error(errno, std::generic_category(), "readlink /proc/self/exe");
  return std::string(buf, static_cast<std::size_t>(n));
}

}  // namespace sensor_rig
