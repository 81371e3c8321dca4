#pragma once
// Cyclone's own ddsperf (ping/pong, round trip) on the same sizes and Cyclone profiles as rig perf:
// the floor a DDS load generator is measured against. One-way is estimated as round trip / 2.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sensor_rig/bench/perf/spec.hpp"

namespace sensor_rig::bench::perf {

struct DdsperfOptions {
  Transport transport = Transport::kUdpTuned;
  std::vector<std::uint32_t> sizes;  // empty: all classes
  double rate_hz = 10;
  double duration_s = 10;
  int domain = -1;
  std::string out;
};

// One ddsperf "ping" stats line: "... size 65536 mean 183.490us min ... 50% ... 90% ... 99% ... max ... cnt 9".
struct DdsperfInterval {
  std::uint32_t size = 0;
  double mean_us = 0, min_us = 0, p50_us = 0, p90_us = 0, p99_us = 0, max_us = 0;
  std::uint64_t cnt = 0;
};
bool parse_ddsperf_line(const std::string& line, DdsperfInterval& out);
// Aggregates intervals (count-weighted means of the per-interval percentiles; min/max exact).
nlohmann::json aggregate_ddsperf(const std::vector<DdsperfInterval>& v);

// The size labels of a ddsperf.json result that got no round trip (pure).
std::vector<std::string> unmeasured_sizes(const nlohmann::json& result);

// Writes DIR/ddsperf.json. Returns 1 (and says which) when a size got no round trip at all.
int run_ddsperf(const DdsperfOptions& o);

}  // namespace sensor_rig::bench::perf
