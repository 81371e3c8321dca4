#include "chaos_fault_end.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sensor_rig::rig::chaos {
namespace {

// Its mock streams without being asked: back when its first part is on the wire.
bool sends_unprompted(const std::string& device_class) { return device_class == "lidar" || device_class == "dbw"; }

const truth::FaultRecord* kill_record(const Input& in, const faults::FaultEvent& e) {
  for (const auto& log : in.truths) {
    if (log.header.device_class != "host") continue;
    for (const auto& f : log.faults)
      if (f.id == e.id && f.kind == e.kind && truth::injected(f)) return &f;
  }
  return nullptr;
}

}  // namespace

double fault_span_s(const faults::FaultEvent& e) {
  double span = e.duration_s;
  if (e.kind == "host.kill_mock") span += e.number("restart_s", 1.0);
  if (e.kind == "host.stall_mock") span += e.number("ms", 300.0) * 1e-3;
  if (e.kind == "camera.slow_open") span += e.number("s", 3.0);
  return span;
}

FaultEnds::FaultEnds(const Input& in) : epoch_vehicle_ns_(in.epoch_vehicle_ns) {
  for (const auto& e : in.events) {
    if (e.kind != "host.kill_mock") continue;
    const truth::FaultRecord* kill = kill_record(in, e);
    if (kill == nullptr) continue;  // not in the host's record: `faults_injected` says so
    const Nanos restarted = kill->until_ns;
    Nanos first_sent = std::numeric_limits<Nanos>::max();
    for (const auto& log : in.truths) {
      if (log.header.device != e.device || !sends_unprompted(log.header.device_class)) continue;
      for (const auto& p : log.parts)
        if (p.tx_ns >= restarted) first_sent = std::min(first_sent, p.tx_ns);
    }
    back_[e.id] = first_sent != std::numeric_limits<Nanos>::max() ? first_sent : restarted;
  }
}

Nanos FaultEnds::end(const faults::FaultEvent& e) const {
  const Nanos planned = epoch_vehicle_ns_ + static_cast<Nanos>(std::llround((e.at_s + fault_span_s(e)) * 1e9));
  const auto it = back_.find(e.id);
  return it != back_.end() && e.kind == "host.kill_mock" ? std::max(planned, it->second) : planned;
}

}  // namespace sensor_rig::rig::chaos
