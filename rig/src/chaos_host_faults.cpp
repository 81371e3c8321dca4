#include "chaos_host_faults.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig::chaos {

HostFaults::HostFaults(std::vector<faults::FaultEvent> events, Nanos epoch_mono, const std::string& truth_path,
                       std::vector<int> loopback_ports)
    : events_(std::move(events)), epoch_mono_(epoch_mono),
      truth_(truth_path, truth::Header{"host", "host", "", "", "", "CLOCK_REALTIME"}),
      loopback_ports_(std::move(loopback_ports)) {}

void HostFaults::start() { thread_ = std::thread([this] { run(); }); }

void HostFaults::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  for (auto& t : hogs_) t.join();
  hogs_.clear();
  steps_.clear();
  delays_.clear();
}

void HostFaults::run() {
  std::size_t next = 0;
  while (!stop_) {
    const Nanos now = monotonic_now_ns();
    // Steps whose fault has ended go back first.
    for (auto it = steps_.begin(); it != steps_.end();) it = it->undo_mono <= now ? steps_.erase(it) : std::next(it);
    for (auto it = delays_.begin(); it != delays_.end();) it = it->undo_mono <= now ? delays_.erase(it) : std::next(it);
    for (; next < events_.size() && at_mono(events_[next].at_s) <= now; ++next) begin(events_[next]);
    if (next == events_.size() && steps_.empty() && delays_.empty()) return;
    ::usleep(2'000);
  }
}

void HostFaults::begin(const faults::FaultEvent& e) {
  const Nanos veh = vehicle_now_ns(), span = static_cast<Nanos>(e.duration_s * 1e9);
  if (e.kind == "host.cpu_hog") {
    const Nanos until = monotonic_now_ns() + span;
    const int threads = std::max(1, static_cast<int>(e.number("threads", 2)));
    for (int i = 0; i < threads; ++i)
      hogs_.emplace_back([this, until] {
        volatile std::uint64_t x = 0;
        while (!stop_ && monotonic_now_ns() < until) x = x + 1;
      });
    truth_.fault({e.id, e.kind, veh, veh + span, -1, "threads=" + std::to_string(threads)});
  } else if (e.kind == "host.clock_step") {
    const auto by = static_cast<Nanos>(e.number("ms", -500) * 1e6);
    try {
      steps_.push_back({monotonic_now_ns() + span, std::make_unique<ClockStep>(by)});
      truth_.fault({e.id, e.kind, veh, veh + span, -1, "ms=" + std::to_string(by / 1'000'000) + ", back after the fault"});
    } catch (const std::exception& ex) {
      log::warn("chaos", std::string("host.clock_step not injected: ") + ex.what());
    }
  } else if (e.kind == "host.network_delay") {
    const double ms = e.number("ms", 50), jitter = e.number("jitter_ms", 0);
    char params[64];
    std::snprintf(params, sizeof params, "ms=%g, jitter_ms=%g", ms, jitter);
    if (e.device == "lo") {
      // netem on the host's loopback for the rig's UDP ports, removed when the fault ends.
      std::string ports;
      for (const int p : loopback_ports_) ports += (ports.empty() ? "" : " ") + std::to_string(p);
      try {
        delays_.push_back({monotonic_now_ns() + span, std::make_unique<LoopbackDelay>(ms, jitter, loopback_ports_)});
        truth_.fault({e.id, e.kind, veh, veh + span, -1, std::string(params) + ", via=netem on lo, udp ports " + ports});
      } catch (const std::exception& ex) {
        log::warn("chaos", std::string("host.network_delay not injected: ") + ex.what());
      }
    } else {
      // Held back in the mocks that send the rig's network traffic: each LIDAR mock holds every
      // datagram ms ± jitter_ms while the fault lasts, in order (netem's jitter reorders; the mock's
      // hold varies gradually so no datagram overtakes another), from the same plan, and records each
      // packet's real send (lidar/mock/README.md); the GigE fake cameras hold their GVSP datagrams and
      // the mock ECU its CAN frames alike (common/network_hold.hpp). Nothing on the host is changed,
      // so nothing is left to undo after the fault, a failed campaign or a kill (the mocks die with rig up).
      truth_.fault({e.id, e.kind, veh, veh + span, -1,
                    std::string(params) + ", via=mocks: lidar, gige cameras, mock ECU (datagrams and CAN frames held, order kept" +
                        (jitter > 0 ? std::string("; hold within ms +- jitter_ms, per datagram") : std::string{}) + ")"});
    }
  } else {
    return;  // a mock's, or rig up's
  }
  truth_.flush();
}

}  // namespace sensor_rig::rig::chaos
