#include "process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace sensor_rig::bench::perf {
namespace {
std::runtime_error sys_error(const std::string& what) { return std::runtime_error(what + ": " + std::strerror(errno)); }

struct SpawnFileActions {
  posix_spawn_file_actions_t fa{};
  SpawnFileActions() { posix_spawn_file_actions_init(&fa); }
  ~SpawnFileActions() { posix_spawn_file_actions_destroy(&fa); }
};
struct SpawnAttr {
  posix_spawnattr_t attr{};
  SpawnAttr() { posix_spawnattr_init(&attr); }
  ~SpawnAttr() { posix_spawnattr_destroy(&attr); }
};
}  // namespace

Child::Child(const std::vector<std::string>& argv, const std::string& stderr_path, bool pipe_stdio, pid_t pgid) {
  int in_pipe[2] = {-1, -1};
  int out_pipe[2] = {-1, -1};
  if (pipe_stdio) {
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
  SpawnFileActions fa;
  if (pipe_stdio) {
    posix_spawn_file_actions_adddup2(&fa.fa, child_in.get(), 0);
    posix_spawn_file_actions_adddup2(&fa.fa, child_out.get(), 1);
  } else {
    posix_spawn_file_actions_addopen(&fa.fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa.fa, 1, stderr_path.empty() ? "/dev/null" : stderr_path.c_str(),
                                     O_WRONLY | O_CREAT | O_APPEND, 0644);
  }
  posix_spawn_file_actions_addopen(&fa.fa, 2, stderr_path.empty() ? "/dev/null" : stderr_path.c_str(),
                                   O_WRONLY | O_CREAT | O_APPEND, 0644);
  SpawnAttr attr;
  // Own process group: Ctrl-C in a terminal reaches the runner only, which then stops its nodes in order.
  posix_spawnattr_setflags(&attr.attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr.attr, pgid);
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int rc = ::posix_spawn(&pid_, argv.at(0).c_str(), &fa.fa, &attr.attr, args.data(), environ);
  if (rc != 0) {
    pid_ = -1;
    throw std::runtime_error("cannot start '" + argv[0] + "': " + std::strerror(rc));
  }
  if (out_) ::fcntl(out_.get(), F_SETFL, O_NONBLOCK);
}

Child::~Child() {
  if (running()) {
    ::kill(pid_, SIGKILL);
    wait_exit(5000);
  }
}

bool Child::send_line(const std::string& line) {
  if (!in_) return false;
  const std::string s = line + "\n";
  const ssize_t n = ::write(in_.get(), s.data(), s.size());  // SIGPIPE is ignored by the rig
  return n == static_cast<ssize_t>(s.size());
}

std::vector<std::string> Child::read_lines() {
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
    break;  // EAGAIN or EOF or error
  }
  std::size_t pos;
  while ((pos = buf_.find('\n')) != std::string::npos) {
    lines.push_back(buf_.substr(0, pos));
    buf_.erase(0, pos + 1);
  }
  return lines;
}

bool Child::poll_exit() {
  if (pid_ <= 0) return true;
  if (info_.exited) return true;
  int status = 0;
  rusage ru{};
  const pid_t r = ::wait4(pid_, &status, WNOHANG, &ru);
  if (r != pid_) return false;
  info_.exited = true;
  if (WIFEXITED(status)) info_.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) info_.term_signal = WTERMSIG(status);
  info_.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e6;
  info_.max_rss_kb = ru.ru_maxrss;
  return true;
}

bool Child::wait_exit(int timeout_ms) {
  for (int waited = 0; !poll_exit(); waited += 10) {
    if (waited >= timeout_ms) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

void Child::signal(int sig) {
  if (running() && !poll_exit()) ::kill(pid_, sig);
}

ProcessUsage process_usage(pid_t pid) {
  ProcessUsage u;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return u;
  // Fields after the parenthesised comm (which may hold spaces): state is field 3, utime 14, stime 15.
  const auto close = line.rfind(')');
  if (close == std::string::npos) return u;
  std::istringstream in(line.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && in >> field; ++i) {
    if (i == 14) utime = std::stoull(field);
    if (i == 15) stime = std::stoull(field);
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

std::string self_exe() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) throw sys_error("readlink /proc/self/exe");
  return std::string(buf, static_cast<std::size_t>(n));
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
    if (std::getline(comm, c) && c == name) pids.push_back(static_cast<pid_t>(pid));
  }
  ::closedir(d);
  return pids;
}

}  // namespace sensor_rig::bench::perf
