#include "sensor_rig/common/child_process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
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
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw sys_error("fork");
  if (pid == 0) {
    // Default signal dispositions in the child; its own shutdown handlers are installed by it.
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    // If this process dies without stopping its children (SIGKILL, crash), they get SIGTERM:
    // no orphaned mock device keeps a port or a bus socket, no orphaned RouDi its shared memory.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(126);  // the parent died between fork and prctl
    if (o.process_group) ::setpgid(0, *o.process_group);
    if (o.pipe_stdio) {
      ::dup2(child_in.get(), 0);
      ::dup2(child_out.get(), 1);
    } else if (log.valid()) {
      const int null_fd = ::open("/dev/null", O_RDONLY);
      if (null_fd >= 0) ::dup2(null_fd, 0);
      ::dup2(log.get(), 1);
    }
    if (log.valid()) ::dup2(log.get(), 2);
    if (o.rt_priority > 0) {
      sched_param sp{};
      sp.sched_priority = o.rt_priority;
      ::sched_setscheduler(0, SCHED_FIFO, &sp);  // kept across exec; refused without privilege: fine
    }
    ::execve(args[0], args.data(), envp.data());
    ::_exit(127);
  }
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
