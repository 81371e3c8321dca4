#pragma once
// The judge's part for the fused cloud (/sensors/lidar/fused/points): its sweeps' members
// (/rig/sets/fused) held against the LIDAR mocks' truth records and the LIDARs' published scans
// (docs/faults.md "The fused cloud"). Called by check() when Input::fused.enabled.
#include <cstdint>
#include <functional>
#include <string>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

// The truth scan the LIDAR judge matched a published scan to (by its first packet's arrival, or
// its stamp): the fused judge uses the same, so that a scan has one truth in the whole verdict.
struct UnitMatch {
  std::int64_t unit = 0;
  Nanos acq = 0;           // true first firing
  Nanos first_intact = 0;  // the first firing that arrived intact (>= acq)
};

struct JudgeContext {
  std::function<bool(Nanos)> doubled;        // vehicle time that happened twice (a clock step): not judged
  std::function<std::string(Nanos)> at_s;    // a vehicle time as seconds into the plan
  std::function<void(const std::string& invariant, const std::string& topic, const std::string& what)> violation;
  std::function<const UnitMatch*(const std::string& topic, std::uint64_t seq)> truth_of;  // nullptr: not matched
  std::function<Nanos(const faults::FaultEvent&)> fault_end;  // when a fault ended for its device (chaos_fault_end.hpp)
};

// Fills r.topics[kFusedCloudTopic] (sent = the fused LIDARs' scans published in the window) and
// reports broken invariants (`fused`, `monitor_agrees`) through ctx.violation.
void check_fused(const Input& in, const JudgeContext& ctx, Result& r);

}  // namespace sensor_rig::rig::chaos
