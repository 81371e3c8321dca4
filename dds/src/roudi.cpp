#include "sensor_rig/dds/roudi.hpp"

#include <grp.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <vector>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::dds {
namespace {
constexpr const char* kRoudiBin = "/usr/bin/iox-roudi";
constexpr const char* kRoudiSocket = "/tmp/roudi";  // iceoryx 2.0: unix datagram socket of RouDi's IPC channel
constexpr Nanos kReadyTimeoutNs = 60'000'000'000;

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

char process_state(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  const auto close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() ? line[close + 2] : '?';
}

// A datagram connect succeeds only while a process is bound to the socket file.
bool socket_bound(const char* path) {
  UniqueFd fd(::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  if (!fd) return false;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path, sizeof addr.sun_path - 1);
  return ::connect(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
}

std::vector<std::string> leftovers() {
  std::vector<std::string> v = {"/dev/shm/iceoryx_mgmt", "/tmp/iox-unique-roudi.lock", kRoudiSocket, "/tmp/roudi.lock"};
  // The payload segment is named after the group that may write it (the user's).
  if (const group* g = ::getgrgid(::getegid()); g != nullptr) v.push_back(std::string("/dev/shm/") + g->gr_name);
  if (const char* user = std::getenv("USER"); user != nullptr && *user != '\0') v.push_back(std::string("/dev/shm/") + user);
  return v;
}

// Each shared-memory participant's iceoryx runtime has a socket and a lock in /tmp, named by
// Cyclone "iceoryx_rt_<pid>_<time>": removed by the runtime at a normal exit, left by a process
// killed (SIGKILL, or RouDi's SIGTERM when it stops first). Those of processes that no longer run.
std::vector<std::string> dead_runtimes_files() {
  std::vector<std::string> v;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/tmp", ec)) {
    const std::string name = e.path().filename().string();
    constexpr std::string_view kPrefix = "iceoryx_rt_";
    if (name.rfind(kPrefix, 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + kPrefix.size(), nullptr, 10);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) v.push_back(e.path().string());
  }
  return v;
}
}  // namespace

RouDiProbe probe_roudi() {
  RouDiProbe p;
  const auto pids = find_processes("iox-roudi");
  if (pids.empty()) return p;
  p.pid = pids.front();
  const char state = process_state(p.pid);
  if (state == 'T' || state == 't') {
    p.problem = "iox-roudi pid " + std::to_string(p.pid) + " is stopped (SIGSTOP or a debugger)";
  } else if (!socket_bound(kRoudiSocket)) {
    p.problem = "iox-roudi pid " + std::to_string(p.pid) + " runs but nothing is bound to " + kRoudiSocket;
  } else {
    p.answers = true;
  }
  return p;
}

int remove_roudi_leftovers() {
  int n = 0;
  std::error_code ec;
  for (const auto& f : dead_runtimes_files()) n += std::filesystem::remove(f, ec) ? 1 : 0;
  if (!find_processes("iox-roudi").empty()) return n;
  for (const auto& f : leftovers()) n += std::filesystem::remove(f, ec) ? 1 : 0;
  return n;
}

RouDi::RouDi(const std::string& config_file, const std::string& log_file, bool allow_external) {
  if (const auto probe = probe_roudi(); probe.pid != 0) {
    if (!probe.answers) throw std::runtime_error("a RouDi is there but does not answer: " + probe.problem + "; stop it first");
    if (!allow_external) {
      throw std::runtime_error("a RouDi (iox-roudi pid " + std::to_string(probe.pid) +
                               ") is already running; only one can run per machine");
    }
    pid_ = external_pid_ = probe.pid;
    return;
  }
  if (::access(kRoudiBin, X_OK) != 0) throw std::runtime_error("shared memory needs iox-roudi (Debian package iceoryx)");
  // Leftovers of a RouDi that died uncleanly would make ours fail; nothing else uses these names.
  if (const int n = remove_roudi_leftovers(); n > 0)
    log::warn("dds", "removed " + std::to_string(n) + " files a previous RouDi left (/dev/shm, /tmp)");
  const Nanos start = monotonic_now_ns();
  // Readiness is read from the log, so a stale one must go first; only a regular file is removed
  // (a log path of /dev/null, removed as root, would take the device with it).
  std::error_code ec;
  const auto st = std::filesystem::symlink_status(log_file, ec);
  if (!ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
    throw std::runtime_error("the RouDi log " + log_file + " is not a regular file (readiness is read from it)");
  std::filesystem::remove(log_file);
  std::vector<std::string> argv{kRoudiBin, "-l", "info", "-m", "on"};
  if (!config_file.empty()) argv.insert(argv.end(), {"-c", config_file});
  ChildOptions o;
  o.log_file = log_file;
  o.process_group = 0;  // Ctrl-C reaches us; we stop it after the nodes that use it
  child_ = std::make_unique<ChildProcess>(argv, o);
  pid_ = child_->pid();
  for (;;) {
    if (read_all(log_file).find("RouDi is ready for clients") != std::string::npos) break;
    if (!child_->running()) {
      throw std::runtime_error("iox-roudi exited during startup (status " + std::to_string(child_->exit_status()) +
                               "); its log " + log_file + ":\n" + read_all(log_file));
    }
    if (monotonic_now_ns() - start > kReadyTimeoutNs) {
      child_->stop(1000);
      throw std::runtime_error("iox-roudi not ready after 60 s; see " + log_file);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  startup_s_ = static_cast<double>(monotonic_now_ns() - start) / 1e9;
}

std::string RouDi::check_alive() {
  if (child_) {
    if (child_->running()) return {};
    const auto& i = child_->exit_info();
    return "iox-roudi pid " + std::to_string(pid_) +
           (i.term_signal != 0 ? " was killed by signal " + std::to_string(i.term_signal)
                               : " exited with status " + std::to_string(i.exit_code));
  }
  if (external_pid_ == 0) return "no RouDi";
  const auto probe = probe_roudi();
  if (probe.pid == external_pid_ && probe.answers) return {};
  return probe.pid == external_pid_ ? probe.problem : "the external iox-roudi pid " + std::to_string(external_pid_) + " is gone";
}

RouDi::~RouDi() { stop(); }

void RouDi::stop() {
  if (!child_) return;
  // RouDi needs a moment to release the shared memory of a large configuration.
  child_->stop(15000);
  stopped_cpu_s_ = child_->exit_info().cpu_s;
  stopped_max_rss_kb_ = child_->exit_info().max_rss_kb;
  child_.reset();
  remove_roudi_leftovers();
}

}  // namespace sensor_rig::dds
