#include "sensor_rig/dbw/bridge/frame_loss_counter.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::dbw {

void FrameLossCounter::on_frame(std::span<const std::uint8_t> payload, safety::E2eStatus st, Nanos now) noexcept {
  using safety::E2eStatus;
  if (!countable()) return;
  const Nanos silence = have_last_ ? now - last_arrival_ : 0;
  longest_silence_ = std::max(longest_silence_, silence);
  last_arrival_ = now;
  // While the counter is frozen it cannot show a loss; the message's period can: frames missing from
  // the silence before this one (never guessed across more than half a counter turn: a stalled ECU).
  std::uint64_t missing_by_time = 0;
  if (period_ns_ > 0) {
    const double periods = static_cast<double>(silence) / period_ns_;
    if (periods < safety::counter_modulus(c_.profile) / 2.0 && periods >= 1.5)
      missing_by_time = static_cast<std::uint64_t>(std::llround(periods)) - 1;
  }
  const bool after_frozen = last_repeated_;
  last_repeated_ = st == E2eStatus::kRepeated;
  if (st == E2eStatus::kRepeated) lost_ += missing_by_time;
  const int modulus = safety::counter_modulus(c_.profile);
  if (!safety::is_ok(st)) {
    ++lost_;
    refused_since_ = true;
    // The value it carried (readable unless the layout is wrong): a position on the counter that is
    // not a loss on the bus.
    if (st != E2eStatus::kBadLayout) {
      const std::uint8_t v = safety::read_counter(c_, payload);
      if (v < modulus) refused_values_ |= 1U << v;
    }
    return;
  }
  const std::uint8_t counter = safety::read_counter(c_, payload);
  if (have_last_) {
    const int skipped = (counter - last_counter_ - 1 + 2 * modulus) % modulus;
    int on_bus = 0;  // skipped values no refused frame carried: lost on the bus
    for (int k = 1; k <= skipped; ++k)
      if ((refused_values_ & (1U << ((last_counter_ + k) % modulus))) == 0) ++on_bus;
    // Frames a silence between two arrivals had room for, at the learned period.
    const double room = period_ns_ > 0 ? static_cast<double>(longest_silence_) / period_ns_ - 1.0 : 0.0;
    if (skipped == 0 && after_frozen) {
      lost_ += missing_by_time;  // the first good frame after a frozen run: only time can tell
    } else if (on_bus > 0 && room > modulus / 2.0) {
      ++gaps_unknown_;  // a restart or a wrapped counter: not guessed
    } else {
      lost_ += static_cast<std::uint64_t>(on_bus);
    }
    // The period from back-to-back good frames only (a slow exponential average: jitter, not gaps).
    const Nanos elapsed = longest_silence_;
    if (skipped == 0 && !refused_since_ && elapsed > 0 && (period_ns_ == 0 || static_cast<double>(elapsed) < 3 * period_ns_))
      period_ns_ = period_ns_ == 0 ? static_cast<double>(elapsed) : 0.9 * period_ns_ + 0.1 * static_cast<double>(elapsed);
  }
  have_last_ = true;
  last_counter_ = counter;
  longest_silence_ = 0;
  refused_values_ = 0;
  refused_since_ = false;
}

}  // namespace sensor_rig::dbw
