#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

#include <algorithm>
#include <stdexcept>

namespace sensor_rig::drivers {

SweepMatcher::SweepMatcher(const SweepMatcherConfig& cfg) : cfg_(cfg) {
  if (cfg_.sources == 0) throw std::invalid_argument("sweep matcher: no sources");
  if (cfg_.max_spread_ns <= 0 || cfg_.timeout_ns <= 0)
    throw std::invalid_argument("sweep matcher: max_spread and timeout must be > 0");
  present_.assign(cfg_.sources, false);
  counters_.missing.assign(cfg_.sources, 0);
}

void SweepMatcher::open(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns) {
  std::fill(present_.begin(), present_.end(), false);
  present_[source] = true;
  count_ = 1;
  open_ = true;
  min_stamp_ = max_stamp_ = stamp_ns;
  opened_at_ = arrival_ns;
}

void SweepMatcher::close(bool complete, std::uint64_t& reason) {
  ++counters_.sweeps;
  ++reason;
  if (!complete)
    for (std::size_t i = 0; i < present_.size(); ++i)
      if (!present_[i]) ++counters_.missing[i];
  emitted_before_ = min_stamp_;
  open_ = false;
}

SweepStep SweepMatcher::push(std::uint32_t source, Nanos stamp_ns, Nanos arrival_ns) {
  SweepStep step;
  if (source >= cfg_.sources || stamp_ns < emitted_before_) {
    ++counters_.late_scans;
    step.late = true;
    return step;
  }
  if (open_) {
    const bool fits = !present_[source] && std::max(max_stamp_, stamp_ns) - std::min(min_stamp_, stamp_ns) <= cfg_.max_spread_ns;
    if (!fits && stamp_ns < min_stamp_) {  // older than the open sweep and not part of it
      ++counters_.late_scans;
      step.late = true;
      return step;
    }
    if (fits) {
      present_[source] = true;
      ++count_;
      min_stamp_ = std::min(min_stamp_, stamp_ns);
      max_stamp_ = std::max(max_stamp_, stamp_ns);
    } else {
      step.emit_open = true;  // the caller emits what the sweep holds before storing this scan
      close(false, counters_.partial_next_sweep);
      open(source, stamp_ns, arrival_ns);
    }
  } else {
    open(source, stamp_ns, arrival_ns);
  }
  step.store = true;
  if (count_ == cfg_.sources) {
    step.emit_after = true;
    close(true, counters_.complete);
  }
  return step;
}

bool SweepMatcher::poll(Nanos now_ns) {
  if (!open_ || now_ns - opened_at_ < cfg_.timeout_ns) return false;
  close(false, counters_.partial_timeout);
  return true;
}

}  // namespace sensor_rig::drivers
