#include "clock_step.hpp"

#include <linux/capability.h>
#include <sys/syscall.h>
#include <sys/timex.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::rig {
namespace {

// The kernel adds the offset in one step (ADJ_SETOFFSET). Read, then set (clock_gettime, then
// clock_settime) lost whatever time passed between the two calls, at every step and again at its
// undo: with a campaign's cpu hog and the rig's real-time threads, 22.4 ms behind after ~30
// campaigns on one VM, 0.83 ms in 1,000 steps of 1 ms. Microseconds, not ADJ_NANO: that mode would
// leave STA_NANO set in the kernel's time status. A negative offset is seconds below it plus
// microseconds in [0, 1 s), as the kernel requires.
bool step_clock(Nanos by) {
  const Nanos us = floor_div(by, Nanos{1'000});
  timex tx{};
  tx.modes = ADJ_SETOFFSET;
  tx.time.tv_sec = static_cast<time_t>(floor_div(us, Nanos{1'000'000}));
  tx.time.tv_usec = static_cast<suseconds_t>(floor_mod(us, Nanos{1'000'000}));
  return ::clock_adjtime(CLOCK_REALTIME, &tx) >= 0;
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
    throw std::runtime_error("clock_adjtime(ADJ_SETOFFSET): " + why);
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
