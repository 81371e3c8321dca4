#pragma once
// What the sweep matcher was handed and what it closed, one CSV line each, so that a campaign's
// grouping can be replayed through SweepMatcher offline (tests/drivers/fusion/campaign_replays.hpp).
// The fused judge of `rig chaos` says which sweep mixed rotations; without the matcher's own inputs
// (stamps, arrival on the monotonic clock, spans, flags) a flake seen once in sixteen campaigns
// could not be replayed. `rig up` writes it under $RIG_LOG_DIR (FusionConfig::matcher_log): every
// campaign keeps it in DIR/logs/fusion_matcher.csv. ~30 lines a second; flushed at each sweep.
#include <cstdint>
#include <cstdio>
#include <string>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::drivers {

class MatcherLog {
 public:
  explicit MatcherLog(const std::string& path);  // empty: off; a file that cannot be opened: warned, off
  ~MatcherLog();
  MatcherLog(const MatcherLog&) = delete;
  MatcherLog& operator=(const MatcherLog&) = delete;

  // A scan pushed: its seq on /rig/stamps, and the sweep it joined (-1: dropped).
  void scan(std::uint32_t source, std::uint64_t seq, Nanos stamp, Nanos arrival, Nanos span, bool unsynchronized,
            std::int64_t sweep);
  // A sweep closed at `now` (monotonic).
  void sweep(Nanos now, std::uint64_t id, bool complete);

 private:
  std::FILE* file_ = nullptr;
};

}  // namespace sensor_rig::drivers
