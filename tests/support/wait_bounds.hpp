#pragma once
// The bound of every wait on DDS discovery and matching, a process coming up, or its first data.
// Such waits return as soon as the condition holds, so the bound costs nothing when all is well;
// it is set for a cold, loaded machine (two cores, an instrumented build beside), where a fixed
// few seconds were missed. A test whose point is timing measures it, not this.
namespace sensor_rig::test {

inline constexpr int kDiscoveryMs = 60'000;

}  // namespace sensor_rig::test
