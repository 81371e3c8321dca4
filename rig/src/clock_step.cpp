#include "clock_step.hpp"

#include <linux/capability.h>
#include <sys/syscall.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace sensor_rig::rig {
namespace {

bool step_clock(Nanos by) {
  timespec ts{};
  if (::clock_gettime(CLOCK_REALTIME, &ts) != 0) return false;
  const Nanos t = static_cast<Nanos>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec + by;
  ts.tv_sec = static_cast<time_t>(t / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t % 1'000'000'000);
  return ::clock_settime(CLOCK_REALTIME, &ts) == 0;
}

}  // namespace

std::string ClockStep::not_permitted() {
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct data[2]{};
  if (::syscall(SYS_capget, &header, data) != 0) return std::string("capget: ") + std::strerror(errno);
  if ((data[CAP_SYS_TIME / 32].effective & (1u << (CAP_SYS_TIME % 32))) == 0)
    return "stepping CLOCK_REALTIME needs CAP_SYS_TIME (root)";
  return {};
}

ClockStep::ClockStep(Nanos step_ns) : step_ns_(step_ns), record_("clock-step", std::to_string(step_ns) + "\n") {
  if (!step_clock(step_ns)) {
    const std::string why = std::strerror(errno);
    record_.remove();
    throw std::runtime_error("clock_settime: " + why);
  }
}

ClockStep::~ClockStep() {
  if (step_clock(-step_ns_)) record_.remove();
}

std::vector<std::string> ClockStep::sweep() {
  std::vector<std::string> undone;
  for (const auto& o : HostChangeRecord::orphans("clock-step")) {
    const Nanos step = std::strtoll(o.content.c_str(), nullptr, 10);
    if (step != 0 && step_clock(-step))
      undone.push_back("stepped CLOCK_REALTIME back by " + std::to_string(step / 1'000'000) +
                       " ms: a campaign (pid " + std::to_string(o.pid) + ") ended without undoing its step");
    HostChangeRecord::remove_orphan(o);
  }
  return undone;
}

}  // namespace sensor_rig::rig
