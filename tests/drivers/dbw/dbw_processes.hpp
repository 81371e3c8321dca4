#pragma once
// Running `rig` children from the dbw process tests: spawn with output to a file, bounded waits.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace sensor_rig::dbw::test {

inline pid_t spawn(const std::vector<std::string>& args, const std::string& out) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// Exit code, 128 when killed by a signal, -1 (after SIGKILL) when it did not end in time.
inline int wait_exit(pid_t pid, int timeout_ms) {
  for (int i = 0; i < timeout_ms / 10; ++i) {
    int st = 0;
    if (::waitpid(pid, &st, WNOHANG) == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : 128;
    ::usleep(10'000);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
  return -1;
}

// Asks a child to finish (SIGINT: `rig` stops its loops and reports) and waits for it.
inline int stop(pid_t pid, int timeout_ms = 5000) {
  ::kill(pid, SIGINT);
  return wait_exit(pid, timeout_ms);
}

}  // namespace sensor_rig::dbw::test
