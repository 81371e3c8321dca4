#pragma once
// Running `rig` children from the dbw process tests. One setup for every test (RigProcesses): the
// binary from RIG_BIN, a work directory, a private DDS domain, the mock ECU listening on a unix bus
// in that directory; children with their output in a file, bounded waits, and none left running
// when an assertion ends a test early.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "dds_domain_lease.hpp"
#include "dbw_test_data.hpp"

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
    argv.reserve(args.size() + 1);
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

// How the children find the test's DDS domain.
enum class DomainBy : std::uint8_t {
  kEnvironment,  // ROS_DOMAIN_ID set for this process (its participants) and every child
  kFlag,         // ROS_DOMAIN_ID removed: the test passes --domain domain() itself
};

// One process test's world:
//   RigProcesses rig("dbw_faults");
//   if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
//   const pid_t mock = rig.start_mock({"--duration", "25"});
//   ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
//   const pid_t bridge = rig.start("bridge", {"dbw", "bridge", "--transport", rig.bus(), ...});
class RigProcesses {
 public:
  // `tag` names the work directory (<tmp>/<tag>_<pid>); the domain is leased, so no test that runs
  // at the same time shares it (tests/support/dds_domain_lease.hpp).
  explicit RigProcesses(const std::string& tag, DomainBy by = DomainBy::kEnvironment)
      : domain_(sensor_rig::test::lease_dds_domain()),
        dir_(std::filesystem::temp_directory_path() / (tag + "_" + std::to_string(::getpid()))) {
    if (const char* b = std::getenv("RIG_BIN"); b != nullptr && std::filesystem::exists(b)) bin_ = b;
    if (by == DomainBy::kEnvironment) {
      ::setenv("ROS_DOMAIN_ID", std::to_string(domain_).c_str(), 1);
    } else {
      ::unsetenv("ROS_DOMAIN_ID");
    }
    std::filesystem::create_directories(dir_);
  }
  // Children still running are killed and reaped; the directory stays when the test failed.
  ~RigProcesses() {
    for (const pid_t pid : children_) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
    if (!::testing::Test::HasFailure()) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
  }
  RigProcesses(const RigProcesses&) = delete;
  RigProcesses& operator=(const RigProcesses&) = delete;

  [[nodiscard]] bool have_rig() const { return !bin_.empty(); }
  [[nodiscard]] const std::string& bin() const { return bin_; }
  [[nodiscard]] int domain() const { return domain_; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] std::string path(const std::string& name) const { return (dir_ / name).string(); }
  [[nodiscard]] std::string bus_socket() const { return path("bus.sock"); }
  [[nodiscard]] std::string bus() const { return "unix:" + bus_socket(); }  // the transport spec for peers
  [[nodiscard]] std::string bus_log() const { return path("bus.log"); }     // the mock's candump log
  // What child `name` wrote (stdout and stderr).
  [[nodiscard]] std::string output(const std::string& name) const { return read_text(dir_ / (name + ".out")); }

  // `rig ARGS...` with stdout and stderr to <dir>/<name>.out.
  pid_t start(const std::string& name, std::vector<std::string> args) {
    args.insert(args.begin(), bin_);
    const pid_t pid = spawn(args, path(name + ".out"));
    if (pid > 0) children_.push_back(pid);
    return pid;
  }
  // `rig mock paravan --transport unix-listen:<bus socket> --log <bus log> ARGS...` as child "mock";
  // waits up to 3 s for the bus socket. -1 (the mock killed) when it did not appear.
  pid_t start_mock(std::vector<std::string> args) {
    std::vector<std::string> a = {"mock", "paravan", "--transport", "unix-listen:" + bus_socket(), "--log", bus_log()};
    a.insert(a.end(), args.begin(), args.end());
    const pid_t pid = start("mock", std::move(a));
    for (int i = 0; i < 300 && !std::filesystem::exists(bus_socket()); ++i) ::usleep(10'000);
    if (std::filesystem::exists(bus_socket())) return pid;
    wait_exit(pid, 0);
    return -1;
  }
  // The child's exit code (see test::wait_exit); it is no longer this object's to kill.
  int wait_exit(pid_t pid, int timeout_ms) {
    children_.erase(std::remove(children_.begin(), children_.end(), pid), children_.end());
    return test::wait_exit(pid, timeout_ms);
  }
  // Asks the child to finish (SIGINT: `rig` stops its loops and reports), then wait_exit.
  int stop(pid_t pid, int timeout_ms = 5000) {
    ::kill(pid, SIGINT);
    return wait_exit(pid, timeout_ms);
  }

 private:
  std::string bin_;
  int domain_;
  std::filesystem::path dir_;
  std::vector<pid_t> children_;
};

}  // namespace sensor_rig::dbw::test
