#include "sensor_rig/common/log.hpp"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::log {
namespace {
Level initial_level() {
  const char* env = std::getenv("RIG_LOG_LEVEL");
  if (env == nullptr) return Level::kInfo;
  const std::string v(env);
  if (v == "debug") return Level::kDebug;
  if (v == "warn") return Level::kWarn;
  if (v == "error") return Level::kError;
  return Level::kInfo;
}
std::atomic<Level> g_level{initial_level()};
std::mutex g_mutex;
constexpr const char* kNames[] = {"debug", "info", "warn", "error"};
}  // namespace

void set_level(Level l) noexcept { g_level.store(l); }
Level level() noexcept { return g_level.load(); }

void write(Level l, std::string_view component, std::string_view message) {
  if (l < g_level.load()) return;
  const double t = static_cast<double>(monotonic_now_ns()) * 1e-9;
  std::lock_guard lock(g_mutex);
  std::fprintf(stderr, "[%12.3f] %-5s %.*s: %.*s\n", t, kNames[static_cast<int>(l)],
               static_cast<int>(component.size()), component.data(), static_cast<int>(message.size()),
               message.data());
}

}  // namespace sensor_rig::log
