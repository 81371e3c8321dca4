#include "sensor_rig/dbw/mock/mock_runner.hpp"

#include <algorithm>
#include <deque>
#include <fstream>

#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dbw/can/candump.hpp"

namespace sensor_rig::dbw::mock {

RunResult run_mock(MockEcu& ecu, can::Transport& bus, const RunOptions& o) {
  RunResult r;
  std::ofstream log;
  if (!o.log_path.empty()) {
    log.open(o.log_path, std::ios::out | std::ios::trunc);
    if (!log) throw can::TransportError("cannot write bus log " + o.log_path);
  }
  auto write_log = [&](Nanos stamp, const can::Frame& f) {
    if (!log.is_open()) return;
    log << can::format_candump_line(stamp, o.iface, f) << '\n';
    ++r.logged;
  };
  const Nanos tick = static_cast<Nanos>(o.tick_ms) * 1'000'000;
  const Nanos start = monotonic_now_ns();
  const Nanos end = o.duration_s > 0 ? start + static_cast<Nanos>(o.duration_s * 1e9) : -1;
  Nanos next_tick = start;
  Nanos next_print = start + 1'000'000'000;
  can::RxFrame rx;
  auto send = [&](const can::Frame& f) {
    const Nanos handed = vehicle_now_ns();
    const bool ok = bus.send(f) == can::IoStatus::kOk;
    const Nanos returned = vehicle_now_ns();
    if (!ok) ++r.send_failures;
    if (o.on_sent) o.on_sent(f, ok && bus.last_send_heard(), handed, returned);
    write_log(returned, f);
  };
  // Frames held by a network delay (o.depart), in the order made: each leaves at its time.
  std::deque<std::pair<Nanos, can::Frame>> held;
  auto send_due = [&](Nanos now) {
    while (!held.empty() && held.front().first <= now) {
      send(held.front().second);
      held.pop_front();
    }
  };
  while (!shutdown_requested()) {
    const Nanos now = monotonic_now_ns();
    if (end > 0 && now >= end) break;
    send_due(now);
    if (now >= next_tick) {
      for (const auto& f : ecu.step(now)) {
        const Nanos due = o.depart ? o.depart(f, now) : now;
        if (held.empty() && due <= now) {
          send(f);
        } else {
          held.emplace_back(std::max(due, held.empty() ? due : held.back().first), f);
        }
      }
      next_tick += tick;
      if (next_tick < now) next_tick = now + tick;
      if (o.print_state && now >= next_print) {
        next_print += 1'000'000'000;
        const auto& s = ecu.model().state();
        std::printf("{\"engaged\":%s,\"speed_mps\":%.3f,\"steer_rad\":%.4f,\"x\":%.2f,\"y\":%.2f,\"yaw\":%.4f,"
                    "\"rx\":%llu,\"e2e_errors\":%llu}\n",
                    ecu.engaged() ? "true" : "false", s.speed, s.steer, s.x, s.y, s.yaw,
                    static_cast<unsigned long long>(ecu.counters().rx_frames),
                    static_cast<unsigned long long>(ecu.counters().rx_e2e_errors));
        std::fflush(stdout);
      }
      continue;
    }
    const Nanos wake = held.empty() ? next_tick : std::min(next_tick, held.front().first);
    const int wait_ms = static_cast<int>((std::max<Nanos>(0, wake - now) + 999'999) / 1'000'000);
    const auto st = bus.receive(rx, wait_ms);
    if (st == can::IoStatus::kOk) {
      write_log(rx.stamp, rx.frame);
      ecu.on_frame(rx.frame, monotonic_now_ns());
    } else if (st == can::IoStatus::kClosed) {
      break;
    }
  }
  // What the network still held when the ECU stopped goes out now: nothing the ECU made is lost by the hold.
  for (const auto& [due, f] : held) send(f);
  log.flush();
  return r;
}

}  // namespace sensor_rig::dbw::mock
