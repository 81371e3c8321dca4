#pragma once
// Child processes the runner starts: pipes to stdin/stdout, stderr to a file, own process group.
// The runner only ever signals PIDs it spawned and has not reaped yet.
#include <sys/types.h>

#include <string>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::bench::perf {

struct ExitInfo {
  bool exited = false;
  int exit_code = -1;
  int term_signal = 0;
  double cpu_s = 0.0;
  long max_rss_kb = 0;
};

class Child {
 public:
  // Starts argv[0] (a path) with the given arguments; stderr appended to `stderr_path` (or /dev/null).
  Child(const std::vector<std::string>& argv, const std::string& stderr_path, bool pipe_stdio, pid_t pgid = 0);
  Child(const Child&) = delete;  // owns a live PID: neither copied nor moved (hold it by unique_ptr)
  Child& operator=(const Child&) = delete;
  ~Child();  // a child still running is SIGKILLed and reaped: never left behind

  [[nodiscard]] pid_t pid() const noexcept { return pid_; }
  [[nodiscard]] bool running() const noexcept { return pid_ > 0 && !info_.exited; }
  [[nodiscard]] const ExitInfo& info() const noexcept { return info_; }
  [[nodiscard]] int stdout_fd() const noexcept { return out_.get(); }

  bool send_line(const std::string& line);  // false when the pipe is closed
  void close_stdin() { in_.reset(); }
  // Reads what is available on stdout (non-blocking) and returns complete lines; sets eof.
  std::vector<std::string> read_lines();
  [[nodiscard]] bool stdout_eof() const noexcept { return eof_; }
  bool poll_exit();            // reaps without blocking; true when it has exited
  bool wait_exit(int timeout_ms);
  void signal(int sig);        // only while running

 private:
  pid_t pid_ = -1;
  UniqueFd in_, out_;
  std::string buf_;
  bool eof_ = false;
  ExitInfo info_;
};

// CPU seconds (user + system) and peak RSS (VmHWM) of a live process, from /proc; known = false when
// it cannot be read (gone, other user).
struct ProcessUsage {
  bool known = false;
  double cpu_s = 0.0;
  long max_rss_kb = 0;
};
ProcessUsage process_usage(pid_t pid);

// /proc/self/exe resolved (the `rig` binary itself).
std::string self_exe();
// PIDs of processes whose comm is `name` (e.g. "iox-roudi").
std::vector<pid_t> find_processes(const std::string& name);

}  // namespace sensor_rig::bench::perf
