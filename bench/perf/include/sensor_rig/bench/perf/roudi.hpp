#pragma once
// RouDi for `rig perf --transport shm`: the daemon itself is supervised by dds::RouDi (shared with
// `rig up`); here only the mempools sized for a run's samples.
#include <cstdint>
#include <string>

#include "sensor_rig/dds/roudi.hpp"

namespace sensor_rig::bench::perf {

using dds::RouDi;

// A RouDi config (TOML) with mempools for `size`-byte samples: `chunks` of them plus small pools.
std::string roudi_config(std::uint32_t size, int chunks);
// Chunks a run needs in the worst practical case: every writer's chunk in flight and a few queued
// per reader (readers take at once; iceoryx shares one chunk among all subscribers of a write).
int roudi_chunks_for(int publishers, int subscriptions);

}  // namespace sensor_rig::bench::perf
