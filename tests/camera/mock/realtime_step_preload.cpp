// LD_PRELOAD into a mock process (rig-fake-gige-camera): its CLOCK_REALTIME steps as a host's does
// under an NTP/PTP servo or the campaign's host.clock_step, without touching the host's clock.
// RIG_TEST_REALTIME_STEPS="AT_MS:STEP_MS[,AT_MS:STEP_MS...]": at AT_MS after the process loaded
// this library (CLOCK_MONOTONIC), CLOCK_REALTIME (clock_gettime, gettimeofday, time) is stepped by
// STEP_MS (negative: back). Every other clock is the kernel's.
#include <sys/syscall.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>

namespace {

struct Step {
  std::int64_t at_mono_ns;
  std::int64_t step_ns;
};
Step g_steps[8];
int g_n = 0;

std::int64_t raw_ns(clockid_t id) {
  timespec ts{};
  ::syscall(SYS_clock_gettime, id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

__attribute__((constructor)) void load_steps() {
  const char* spec = std::getenv("RIG_TEST_REALTIME_STEPS");
  const std::int64_t loaded = raw_ns(CLOCK_MONOTONIC);
  while (spec != nullptr && *spec != '\0' && g_n < 8) {
    char* end = nullptr;
    const double at_ms = std::strtod(spec, &end);
    if (end == spec || *end != ':') break;
    spec = end + 1;
    const double step_ms = std::strtod(spec, &end);
    if (end == spec) break;
    g_steps[g_n++] = Step{loaded + static_cast<std::int64_t>(at_ms * 1e6), static_cast<std::int64_t>(step_ms * 1e6)};
    spec = *end == ',' ? end + 1 : end;
  }
}

std::int64_t offset_ns() {
  const std::int64_t now = raw_ns(CLOCK_MONOTONIC);
  std::int64_t off = 0;
  for (int i = 0; i < g_n; ++i)
    if (now >= g_steps[i].at_mono_ns) off += g_steps[i].step_ns;
  return off;
}

}  // namespace

extern "C" int clock_gettime(clockid_t id, timespec* ts) noexcept {
  const long rc = ::syscall(SYS_clock_gettime, id, ts);
  if (rc != 0 || (id != CLOCK_REALTIME && id != CLOCK_REALTIME_COARSE)) return static_cast<int>(rc);
  const std::int64_t ns = static_cast<std::int64_t>(ts->tv_sec) * 1'000'000'000 + ts->tv_nsec + offset_ns();
  ts->tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts->tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return 0;
}

extern "C" int gettimeofday(timeval* __restrict tv, void* __restrict /*tz*/) noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  if (tv != nullptr) {
    tv->tv_sec = ts.tv_sec;
    tv->tv_usec = static_cast<suseconds_t>(ts.tv_nsec / 1000);
  }
  return 0;
}

extern "C" time_t time(time_t* out) noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  if (out != nullptr) *out = ts.tv_sec;
  return ts.tv_sec;
}
