#pragma once
// Process-wide stop request, set by SIGINT/SIGTERM; loops poll it between bounded waits.
#include <atomic>

namespace sensor_rig {

void install_shutdown_handlers();       // SIGINT, SIGTERM -> request_shutdown(); SIGPIPE ignored
void request_shutdown() noexcept;
[[nodiscard]] bool shutdown_requested() noexcept;
// Sleeps up to `ms`, returning early (true) when shutdown is requested.
bool wait_for_shutdown(int ms) noexcept;

}  // namespace sensor_rig
