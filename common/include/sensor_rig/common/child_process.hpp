#pragma once
// Children this process started (mock devices, nodes, iox-roudi, `rig perf` nodes): clone/exec,
// stopped with SIGTERM then SIGKILL after a grace period. Only ever signals PIDs it created itself
// and has not reaped yet. A child gets SIGTERM when this process dies without stopping it.
#include <sys/resource.h>
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig {

struct ChildOptions {
  int rt_priority = 0;       // > 0: SCHED_FIFO at that priority when permitted (else normal)
  std::string log_file;      // stderr (and stdout unless piped) appended here; empty: inherited
  bool pipe_stdio = false;   // stdin/stdout are pipes to this process (send_line / read_lines)
  // 0: a new process group of its own (Ctrl-C in a terminal reaches only us, we stop it in order);
  // a pid: join that group; unset: stay in ours.
  std::optional<pid_t> process_group;
  std::vector<std::string> env;  // "NAME=value", added to (or replacing in) our environment
};

// How a reaped child ended and what it used (wait4).
struct ExitInfo {
  bool exited = false;
  int exit_code = -1;   // when it exited normally
  int term_signal = 0;  // when a signal ended it
  double cpu_s = 0.0;   // user + system
  long max_rss_kb = 0;
};

// The child gets SIGTERM when its parent dies (PR_SET_PDEATHSIG). Linux counts the parent *thread*:
// create a ChildProcess on a thread that lives as long as the child should (rig/src/mock_faults.cpp).
class ChildProcess {
 public:
  ChildProcess() = default;
  // argv[0] is the program path; throws std::system_error when clone or a pipe fails (a program that
  // cannot be executed exits with status 127).
  explicit ChildProcess(std::vector<std::string> argv, int rt_priority = 0);
  ChildProcess(std::vector<std::string> argv, const ChildOptions& options);
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ChildProcess(ChildProcess&& o) noexcept;
  ChildProcess& operator=(ChildProcess&& o) noexcept;
  ~ChildProcess();  // a child still running is stopped (SIGTERM, 2 s, SIGKILL) and reaped

  [[nodiscard]] pid_t pid() const noexcept { return pid_; }
  [[nodiscard]] bool running();  // reaps it when it has exited
  // Exit status once reaped: exit code, or 128 + signal; -1 while running.
  [[nodiscard]] int exit_status() const noexcept { return status_; }
  [[nodiscard]] const ExitInfo& exit_info() const noexcept { return info_; }
  // SIGTERM, wait up to grace_ms, then SIGKILL. Returns the exit status.
  int stop(int grace_ms = 2000);
  bool wait_exit(int timeout_ms);  // true when it has exited (reaped) within the time
  void signal(int sig);            // only while running (never a reaped, possibly reused PID)
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

  // With pipe_stdio:
  bool send_line(const std::string& line);  // false when the pipe is closed (SIGPIPE ignored, as rig does)
  void close_stdin() { in_.reset(); }
  // What is available on stdout (non-blocking) as complete lines; sets stdout_eof().
  std::vector<std::string> read_lines();
  [[nodiscard]] bool stdout_eof() const noexcept { return eof_; }
  [[nodiscard]] int stdout_fd() const noexcept { return out_.get(); }

 private:
  void reaped(int wait_status, const ::rusage& ru);
  pid_t pid_ = -1;
  pid_t last_pid_ = -1;  // for messages after it was reaped
  int status_ = -1;
  ExitInfo info_;
  std::string name_;
  UniqueFd in_, out_;
  std::string buf_;
  bool eof_ = false;
};

// Path of the running executable (/proc/self/exe), to start sibling `rig` subcommands.
std::string self_executable();

// CPU seconds (user + system) and peak RSS (VmHWM) of a live process, from /proc; known = false
// when it cannot be read (gone, another user's).
struct ProcessUsage {
  bool known = false;
  double cpu_s = 0.0;
  long max_rss_kb = 0;
};
ProcessUsage process_usage(pid_t pid);
// PIDs of live (not zombie) processes whose comm is `name` (e.g. "iox-roudi").
std::vector<pid_t> find_processes(const std::string& name);

}  // namespace sensor_rig
