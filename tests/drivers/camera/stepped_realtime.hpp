#pragma once
// A CLOCK_REALTIME this test process can step without touching the host's clock: the executable
// that includes this header (once, in one translation unit) defines clock_gettime, which the
// dynamic linker binds every caller in the process to (the rig's vehicle_now_ns(), the fakes'
// truth records, Cyclone). CLOCK_REALTIME reads the kernel's clock plus an offset the test steps;
// every other clock is the kernel's. Include it only in an executable of its own.
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>

namespace sensor_rig::test {

inline std::atomic<std::int64_t>& realtime_step_offset_ns() {
  static std::atomic<std::int64_t> offset{0};
  return offset;
}
// Steps this process's CLOCK_REALTIME by `ns` (negative: back), as `date -s` or ptp4l would.
inline void step_realtime(std::int64_t ns) { realtime_step_offset_ns().fetch_add(ns); }

}  // namespace sensor_rig::test

extern "C" int clock_gettime(clockid_t id, timespec* ts) noexcept {
  const long rc = ::syscall(SYS_clock_gettime, id, ts);
  if (rc != 0 || id != CLOCK_REALTIME) return static_cast<int>(rc);
  const std::int64_t ns = static_cast<std::int64_t>(ts->tv_sec) * 1'000'000'000 + ts->tv_nsec +
                          sensor_rig::test::realtime_step_offset_ns().load();
  ts->tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts->tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return 0;
}
