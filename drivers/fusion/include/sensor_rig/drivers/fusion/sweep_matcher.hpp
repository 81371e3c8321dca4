#pragma once
// Which LIDAR scans make one sweep of the fused cloud. Pure: stamps and arrival times are
// arguments, no clock, no threads, no points (the node keeps those per source).
//
// The first scan opens a sweep; a scan of another source joins it while the sweep's stamps stay
// within `max_spread_ns` (one rotation: every LIDAR delivers one scan per period, whatever its
// phase). The sweep is emitted when every source has joined (complete), or as a subset when
// - a source delivers again, or a scan's stamp would stretch the sweep beyond max_spread (the
//   next sweep began: the open one is closed first, then the scan opens the next), or
// - `timeout_ns` passed since the sweep opened (arrival time; poll()).
// A scan stamped before the last emitted sweep's first stamp, or before the open sweep and too far
// from it to join, is late and dropped.
#include <cstdint>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::drivers {

struct SweepMatcherConfig {
  std::uint32_t sources = 1;
  Nanos max_spread_ns = 100'000'000;  // one rotation at 600 rpm
  Nanos timeout_ns = 150'000'000;     // > max_spread: the latest phase still makes it
};

// What push() asks the caller to do, in this order.
struct SweepStep {
  bool emit_open = false;   // emit the sweep as it was before this scan (a subset: next sweep began)
  bool store = false;       // keep this scan as its source's part of the (new) open sweep
  bool emit_after = false;  // then emit the open sweep (this scan completed it)
  bool late = false;        // the scan is dropped
};

struct SweepCounters {
  std::uint64_t sweeps = 0;              // emitted
  std::uint64_t complete = 0;
  std::uint64_t partial_timeout = 0;     // subsets emitted by the timeout
  std::uint64_t partial_next_sweep = 0;  // subsets closed by the next sweep's first scan
  std::uint64_t late_scans = 0;
  std::vector<std::uint64_t> missing;    // per source: emitted sweeps without its scan
};

class SweepMatcher {
 public:
  explicit SweepMatcher(const SweepMatcherConfig& cfg);  // throws std::invalid_argument

  SweepStep push(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns);
  // True when the open sweep timed out: emit it (a subset) now.
  bool poll(Nanos now_ns);
  // Arrival deadline of the open sweep (poll then), or -1 when none is open.
  [[nodiscard]] Nanos deadline() const noexcept { return open_ ? opened_at_ + cfg_.timeout_ns : -1; }
  [[nodiscard]] const SweepCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const SweepMatcherConfig& config() const noexcept { return cfg_; }

 private:
  void open(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns);
  void close(bool complete, std::uint64_t& reason);

  SweepMatcherConfig cfg_;
  SweepCounters counters_;
  std::vector<bool> present_;
  std::uint32_t count_ = 0;
  bool open_ = false;
  Nanos min_stamp_ = 0, max_stamp_ = 0, opened_at_ = 0;
  Nanos emitted_before_ = INT64_MIN;  // the last emitted sweep's first stamp
};

}  // namespace sensor_rig::drivers
