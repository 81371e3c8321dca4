#include "sensor_rig/common/shutdown.hpp"

#include <csignal>
#include <ctime>

namespace sensor_rig {
namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_signal(int /*sig*/) { g_stop.store(true); }
}  // namespace

void install_shutdown_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}
void request_shutdown() noexcept { g_stop.store(true); }
bool shutdown_requested() noexcept { return g_stop.load(); }

bool wait_for_shutdown(int ms) noexcept {
  constexpr int kStepMs = 20;
  for (int waited = 0; waited < ms; waited += kStepMs) {
    if (g_stop.load()) return true;
    const int step = ms - waited < kStepMs ? ms - waited : kStepMs;
    timespec ts{0, static_cast<long>(step) * 1'000'000L};
    nanosleep(&ts, nullptr);
  }
  return g_stop.load();
}

}  // namespace sensor_rig
