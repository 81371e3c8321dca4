#include "chaos_mock_back.hpp"

#include <algorithm>
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

Nanos back_after(const Input& in, const faults::FaultEvent& e, Nanos planned_end) {
  if (e.kind != "host.kill_mock") return planned_end;
  const truth::FaultRecord* kill = kill_record(in, e);
  if (kill == nullptr) return planned_end;  // not in the host's record: `faults_injected` says so
  const Nanos restarted = kill->until_ns;
  Nanos first_sent = std::numeric_limits<Nanos>::max();
  for (const auto& log : in.truths) {
    if (log.header.device != e.device || !sends_unprompted(log.header.device_class)) continue;
    for (const auto& p : log.parts)
      if (p.tx_ns >= restarted) first_sent = std::min(first_sent, p.tx_ns);
  }
  const Nanos back = first_sent != std::numeric_limits<Nanos>::max() ? first_sent : restarted;
  return std::max(planned_end, back);
}

}  // namespace sensor_rig::rig::chaos
