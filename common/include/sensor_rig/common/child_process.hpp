#pragma once
// Children this process started (mock devices, nodes): started with fork/exec, stopped with
// SIGTERM then SIGKILL after a grace period. Only ever signals PIDs it created itself.
#include <sys/types.h>

#include <string>
#include <vector>

namespace sensor_rig {

class ChildProcess {
 public:
  ChildProcess() = default;
  // argv[0] is the program path; throws std::system_error when fork fails or exec is impossible.
  // rt_priority > 0: the child runs SCHED_FIFO at that priority when permitted (else normal).
  explicit ChildProcess(std::vector<std::string> argv, int rt_priority = 0);
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ChildProcess(ChildProcess&& o) noexcept;
  ChildProcess& operator=(ChildProcess&& o) noexcept;
  ~ChildProcess();

  [[nodiscard]] pid_t pid() const noexcept { return pid_; }
  [[nodiscard]] bool running();  // reaps it when it has exited
  // Exit status once reaped: exit code, or 128 + signal; -1 while running.
  [[nodiscard]] int exit_status() const noexcept { return status_; }
  // SIGTERM, wait up to grace_ms, then SIGKILL. Returns the exit status.
  int stop(int grace_ms = 2000);
  [[nodiscard]] const std::string& name() const noexcept { return name_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::string name_;
};

// Path of the running executable (/proc/self/exe), to start sibling `rig` subcommands.
std::string self_executable();

}  // namespace sensor_rig
