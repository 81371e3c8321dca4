#include "clock_step.hpp"

#include <linux/capability.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace sensor_rig::rig {
namespace {

namespace fs = std::filesystem;

fs::path state_dir() {
  const char* dir = std::getenv("RIG_STATE_DIR");
  return dir != nullptr && *dir != '\0' ? fs::path(dir) : fs::path("/run/sensor-rig");
}

bool step_clock(Nanos by) {
  timespec ts{};
  if (::clock_gettime(CLOCK_REALTIME, &ts) != 0) return false;
  const Nanos t = static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec + by;
  ts.tv_sec = static_cast<time_t>(t / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t % 1'000'000'000);
  return ::clock_settime(CLOCK_REALTIME, &ts) == 0;
}

std::atomic<int> g_counter{0};

}  // namespace

bool process_running(long pid) {
  if (pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;  // no /proc: kill() said it exists
  const auto paren = line.rfind(')');
  return paren == std::string::npos || paren + 2 >= line.size() || line[paren + 2] != 'Z';
}

std::string ClockStep::not_permitted() {
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2]{};
  if (::syscall(SYS_capget, &header, data) != 0) return std::string("capget: ") + std::strerror(errno);
  if ((data[CAP_SYS_TIME / 32].effective & (1u << (CAP_SYS_TIME % 32))) == 0)
    return "stepping CLOCK_REALTIME needs CAP_SYS_TIME (root)";
  return {};
}

ClockStep::ClockStep(Nanos step_ns) : step_ns_(step_ns) {
  std::error_code ec;
  fs::create_directories(state_dir(), ec);
  record_ = (state_dir() / ("clock-step-" + std::to_string(::getpid()) + "-" + std::to_string(g_counter++))).string();
  {
    std::ofstream out(record_, std::ios::trunc);
    out << step_ns << '\n';
    if (!out) throw std::runtime_error("cannot record the clock step in " + record_);
  }
  if (!step_clock(step_ns)) {
    const std::string why = std::strerror(errno);
    fs::remove(record_, ec);
    throw std::runtime_error("clock_settime: " + why);
  }
}

ClockStep::~ClockStep() {
  if (step_clock(-step_ns_)) {
    std::error_code ec;
    fs::remove(record_, ec);
    fs::remove(state_dir(), ec);  // fails, harmlessly, while it holds anything else
  }
}

std::vector<std::string> ClockStep::sweep() {
  std::vector<std::string> undone;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(state_dir(), ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("clock-step-", 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + 11, nullptr, 10);
    if (pid <= 0 || process_running(pid)) continue;  // its owner runs
    Nanos step = 0;
    std::ifstream(e.path()) >> step;
    if (step != 0 && step_clock(-step))
      undone.push_back("stepped CLOCK_REALTIME back by " + std::to_string(step / 1'000'000) +
                       " ms: a campaign (pid " + std::to_string(pid) + ") ended without undoing its step");
    fs::remove(e.path(), ec);
  }
  fs::remove(state_dir(), ec);
  return undone;
}

}  // namespace sensor_rig::rig
