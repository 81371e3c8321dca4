#include "sensor_rig/common/child_process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>

#include "sensor_rig/common/clock.hpp"

extern char** environ;

namespace sensor_rig {
namespace {

std::system_error sys_error(const char* what) { return {errno, std::generic_category(), what}; }

// Our environment with `extra` ("NAME=value") added or replacing, built before fork (no
// allocation between fork and exec).
std::vector<std::string> merged_environment(const std::vector<std::string>& extra) {
  std::vector<std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string kv = *e;
    const std::string key = kv.substr(0, kv.find('=') + 1);
    bool replaced = false;
    for (const auto& x : extra) replaced = replaced || x.rfind(key, 0) == 0;
    if (!replaced) env.push_back(kv);
  }
  env.insert(env.end(), extra.begin(), extra.end());
  return env;
}

std::vector<char*> c_strings(std::vector<std::string>& v) {
  std::vector<char*> out;
  out.reserve(v.size() + 1);
  for (auto& s : v) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

// What the child needs between clone and exec, all made before: it shares our memory and may not
// allocate, lock or unwind.
struct SpawnArgs {
  char* const* argv = nullptr;
  char* const* envp = nullptr;
  pid_t parent = 0;
  bool set_group = false;
  pid_t group = 0;
  int stdin_fd = -1, stdout_fd = -1, stderr_fd = -1;  // -1: inherited
  int rt_priority = 0;
  sigset_t mask{};  // the caller's signal mask, restored just before exec
};

// The kernel's struct sigaction (x86-64, arm64): what rt_sigaction reads and writes.
struct KernelSigaction {
  void* handler = nullptr;
  unsigned long flags = 0;
  void* restorer = nullptr;
  unsigned long mask = 0;
};
constexpr long kKernelSigsetBytes = 8;

// fd on `target` for the program, kept across exec (dup3 clears close-on-exec; a descriptor that is
// already `target` keeps its flag, so it is cleared by hand).
void place_fd(int fd, int target) {
  if (fd < 0) return;
  if (fd == target)
    ::syscall(SYS_fcntl, fd, F_SETFD, 0);
  else
    ::syscall(SYS_dup3, fd, target, 0);
}

// The child until exec, in our memory on a stack of its own: system calls only, made directly, and
// no sanitizer's hooks (they would write the sanitizer's state of this thread, shared with us: a
// sigaction through TSan's would have reset our own handler table).
__attribute__((no_sanitize("address", "thread", "undefined"))) int child_main(void* p) {
  const SpawnArgs& a = *static_cast<const SpawnArgs*>(p);
  // Every signal is blocked here (spawn). A handler of ours must not run in the child: those with
  // one go back to the default first, SIGINT and SIGTERM also when we ignore them (the child
  // installs its own shutdown handlers); what we ignore (SIGPIPE) stays ignored, as across fork.
  KernelSigaction dfl;  // SIG_DFL is a null handler
  for (int sig = 1; sig < _NSIG; ++sig) {
    KernelSigaction cur;
    if (::syscall(SYS_rt_sigaction, sig, nullptr, &cur, kKernelSigsetBytes) != 0) continue;
    const bool ignored = reinterpret_cast<std::uintptr_t>(cur.handler) == 1;  // SIG_IGN
    if (sig == SIGINT || sig == SIGTERM || (cur.handler != nullptr && !ignored))
      ::syscall(SYS_rt_sigaction, sig, &dfl, nullptr, kKernelSigsetBytes);
  }
  // If this process dies without stopping its children (SIGKILL, crash), they get SIGTERM:
  // no orphaned mock device keeps a port or a bus socket, no orphaned RouDi its shared memory.
  ::syscall(SYS_prctl, PR_SET_PDEATHSIG, SIGTERM, 0, 0, 0);
  if (::syscall(SYS_getppid) != a.parent) ::syscall(SYS_exit_group, 126);  // the parent died between clone and prctl
  if (a.set_group) ::syscall(SYS_setpgid, 0, a.group);
  place_fd(a.stdin_fd, 0);
  place_fd(a.stdout_fd, 1);
  place_fd(a.stderr_fd, 2);
  if (a.rt_priority > 0) {
    sched_param sp{};
    sp.sched_priority = a.rt_priority;
    ::syscall(SYS_sched_setscheduler, 0, SCHED_FIFO, &sp);  // kept across exec; refused without privilege: fine
  }
  ::syscall(SYS_rt_sigprocmask, SIG_SETMASK, &a.mask, nullptr, kKernelSigsetBytes);
  ::syscall(SYS_execve, a.argv[0], a.argv, a.envp);
  ::syscall(SYS_exit_group, 127);
  return 127;
}

// clone(CLONE_VM | CLONE_VFORK), as posix_spawn does, not fork: fork copied the page tables of the
// whole rig (50 threads, 1.5 GB mapped) and write-protected its memory for copy-on-write, so that a
// mock restarted under load (host.kill_mock) started 370-490 ms late and every thread of the rig
// took a page fault per page it wrote next. This thread waits until the child has exec'd.
pid_t spawn(SpawnArgs& a) {
  constexpr std::size_t kStackBytes = 64 * 1024;
  std::vector<char> stack(kStackBytes);
  sigset_t all;
  ::sigfillset(&all);
  ::pthread_sigmask(SIG_SETMASK, &all, &a.mask);
  const pid_t pid = ::clone(child_main, stack.data() + kStackBytes, CLONE_VM | CLONE_VFORK | SIGCHLD, &a);
  const int err = errno;
  ::pthread_sigmask(SIG_SETMASK, &a.mask, nullptr);
  errno = err;
  return pid;
}

}  // namespace

namespace {
ChildOptions with_priority(int rt_priority) {
  ChildOptions o;
  o.rt_priority = rt_priority;
  return o;
}
}  // namespace

ChildProcess::ChildProcess(std::vector<std::string> argv, int rt_priority)
    : ChildProcess(std::move(argv), with_priority(rt_priority)) {}

ChildProcess::ChildProcess(std::vector<std::string> argv, const ChildOptions& o) {
  if (argv.empty()) throw std::invalid_argument("ChildProcess: empty argv");
  name_ = argv[0];
  for (std::size_t i = 1; i < argv.size() && i < 3; ++i) name_ += " " + argv[i];
  auto args = c_strings(argv);
  std::vector<std::string> env_strings = merged_environment(o.env);
  auto envp = c_strings(env_strings);
  int in_pipe[2] = {-1, -1};
  int out_pipe[2] = {-1, -1};
  if (o.pipe_stdio) {
    if (::pipe2(in_pipe, O_CLOEXEC) != 0) throw sys_error("pipe");
    if (::pipe2(out_pipe, O_CLOEXEC) != 0) {
      ::close(in_pipe[0]);
      ::close(in_pipe[1]);
      throw sys_error("pipe");
    }
  }
  UniqueFd child_in(in_pipe[0]), child_out(out_pipe[1]);
  in_.reset(in_pipe[1]);
  out_.reset(out_pipe[0]);
  int log_fd = -1;
  if (!o.log_file.empty()) {
    log_fd = ::open(o.log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log_fd < 0) throw sys_error(("open " + o.log_file).c_str());
  }
  UniqueFd log(log_fd);
  const int null_fd = !o.pipe_stdio && log.valid() ? ::open("/dev/null", O_RDONLY | O_CLOEXEC) : -1;
  UniqueFd null_in(null_fd);
  SpawnArgs a;
  a.argv = args.data();
  a.envp = envp.data();
  a.parent = ::getpid();
  a.set_group = o.process_group.has_value();
  a.group = o.process_group.value_or(0);
  a.stdin_fd = o.pipe_stdio ? child_in.get() : null_in.get();
  a.stdout_fd = o.pipe_stdio ? child_out.get() : log.get();
  a.stderr_fd = log.get();
  a.rt_priority = o.rt_priority;
  const pid_t pid = spawn(a);
  if (pid < 0) throw sys_error("clone");
  pid_ = last_pid_ = pid;
  if (o.process_group) ::setpgid(pid, *o.process_group);  // also here: no race with the first signal
  if (out_) ::fcntl(out_.get(), F_SETFL, O_NONBLOCK);
}

ChildProcess::ChildProcess(ChildProcess&& o) noexcept
    : pid_(std::exchange(o.pid_, -1)),
      last_pid_(o.last_pid_),
      status_(o.status_),
      info_(o.info_),
      name_(std::move(o.name_)),
      in_(std::move(o.in_)),
      out_(std::move(o.out_)),
      buf_(std::move(o.buf_)),
      eof_(o.eof_) {}

ChildProcess& ChildProcess::operator=(ChildProcess&& o) noexcept {
  if (this != &o) {
    if (pid_ > 0) stop();
    pid_ = std::exchange(o.pid_, -1);
    last_pid_ = o.last_pid_;
    status_ = o.status_;
    info_ = o.info_;
    name_ = std::move(o.name_);
    in_ = std::move(o.in_);
    out_ = std::move(o.out_);
    buf_ = std::move(o.buf_);
    eof_ = o.eof_;
  }
  return *this;
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0) stop();
}

void ChildProcess::reaped(int st, const ::rusage& ru) {
  info_.exited = true;
  if (WIFEXITED(st)) info_.exit_code = WEXITSTATUS(st);
  if (WIFSIGNALED(st)) info_.term_signal = WTERMSIG(st);
  info_.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e6;
  info_.max_rss_kb = ru.ru_maxrss;
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  pid_ = -1;
}

bool ChildProcess::running() {
  if (pid_ <= 0) return false;
  int st = 0;
  ::rusage ru{};
  const pid_t r = ::wait4(pid_, &st, WNOHANG, &ru);
  if (r == 0) return true;
  if (r == pid_) {
    reaped(st, ru);
  } else {
    pid_ = -1;  // reaped elsewhere (ECHILD): nothing left to signal
  }
  return false;
}

bool ChildProcess::wait_exit(int timeout_ms) {
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(timeout_ms) * 1'000'000;
  while (running()) {
    if (monotonic_now_ns() >= deadline) return false;
    ::usleep(5'000);
  }
  return true;
}

void ChildProcess::signal(int sig) {
  if (running()) ::kill(pid_, sig);
}

int ChildProcess::stop(int grace_ms) {
  if (!running()) return status_;
  ::kill(pid_, SIGTERM);
  if (wait_exit(grace_ms)) return status_;
  ::kill(pid_, SIGKILL);
  int st = 0;
  ::rusage ru{};
  if (::wait4(pid_, &st, 0, &ru) == pid_) {
    reaped(st, ru);
  } else {
    pid_ = -1;
  }
  return status_;
}

bool ChildProcess::send_line(const std::string& line) {
  if (!in_) return false;
  const std::string s = line + "\n";
  const ssize_t n = ::write(in_.get(), s.data(), s.size());  // SIGPIPE is ignored by the rig
  return n == static_cast<ssize_t>(s.size());
}

std::vector<std::string> ChildProcess::read_lines() {
  std::vector<std::string> lines;
  if (!out_ || eof_) return lines;
  char tmp[512];
  for (;;) {
    const ssize_t n = ::read(out_.get(), tmp, sizeof tmp);
    if (n > 0) {
      buf_.append(tmp, static_cast<std::size_t>(n));
      continue;
    }
    if (n == 0) eof_ = true;
    break;  // EAGAIN, EOF or an error
  }
  std::size_t pos;
  while ((pos = buf_.find('\n')) != std::string::npos) {
    lines.push_back(buf_.substr(0, pos));
    buf_.erase(0, pos + 1);
  }
  return lines;
}

std::string self_executable() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) throw sys_error("readlink /proc/self/exe");
  return std::string(buf, static_cast<std::size_t>(n));
}

ProcessUsage process_usage(pid_t pid) {
  ProcessUsage u;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return u;
  // Fields after the parenthesised comm (which may hold spaces): state is field 3, utime 14, stime 15.
  const auto close = line.rfind(')');
  if (close == std::string::npos || close + 2 > line.size()) return u;
  std::istringstream in(line.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> field; ++i) {
    if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
    if (i == 15) stime = std::strtoull(field.c_str(), nullptr, 10);
  }
  const long hz = ::sysconf(_SC_CLK_TCK);
  u.cpu_s = static_cast<double>(utime + stime) / static_cast<double>(hz > 0 ? hz : 100);
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) u.max_rss_kb = std::strtol(line.c_str() + 6, nullptr, 10);
  }
  u.known = true;
  return u;
}

std::vector<pid_t> find_processes(const std::string& name) {
  std::vector<pid_t> pids;
  DIR* d = ::opendir("/proc");
  if (d == nullptr) return pids;
  while (const dirent* e = ::readdir(d)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (end == e->d_name || *end != '\0') continue;
    std::ifstream comm(std::string("/proc/") + e->d_name + "/comm");
    std::string c;
    if (!std::getline(comm, c) || c != name) continue;
    std::ifstream stat(std::string("/proc/") + e->d_name + "/stat");
    std::string line;
    std::getline(stat, line);
    const auto close = line.rfind(')');
    if (close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z') continue;  // a zombie
    pids.push_back(static_cast<pid_t>(pid));
  }
  ::closedir(d);
  return pids;
}

}  // namespace sensor_rig
