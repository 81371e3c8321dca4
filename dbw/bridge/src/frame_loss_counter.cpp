#include "sensor_rig/dbw/bridge/frame_loss_counter.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace sensor_rig::dbw {
namespace {

// A frame that arrived at `now` was sent `periods` periods after the one whose send time `sent`
// estimates, so that one was sent by `now` less as many periods. Taken when it is earlier by half a
// period at least (a network hold delayed both); less is the sender's jitter.
void pull_back_send_estimate(Nanos& sent, Nanos now, double periods, double period_ns) noexcept {
  const Nanos by = now - static_cast<Nanos>(periods * period_ns);
  if (2 * static_cast<double>(sent - by) > period_ns) sent = by;
}

}  // namespace

// While the counter is frozen it cannot show a loss; the message's period can. Counted once, over
// the whole run from the last good frame to this one: the frames the span had room for at the
// learned period, less every frame that arrived meanwhile (each refused one already counted). Per
// silence instead, a frame 6 ms late followed by one 6 ms early (a loaded host) counted a frame lost
// that was jitter (rig chaos: "the rig counted 162 can_frames lost, 161 were not published"). Never
// guessed across a silence of more than half a counter turn (a stalled ECU: frames never sent).
// Frames the span since the last good frame had room for, at the learned period (> 0).
double FrameLossCounter::slots_since_good(Nanos now) const noexcept {
  return static_cast<double>(now - last_good_arrival_) / period_ns_ - 1.0;
}

std::uint64_t FrameLossCounter::missing_while_frozen(const FrozenRun& run) const noexcept {
  if (run.period_ns <= 0 || static_cast<double>(run.longest_silence) / run.period_ns >= safety::counter_modulus(c_.profile) / 2.0) return 0;
  const auto room = std::llround(static_cast<double>(run.end - run.from) / run.period_ns - 1.0);
  return room > static_cast<long long>(run.arrived) ? static_cast<std::uint64_t>(room) - run.arrived : 0;
}

void FrameLossCounter::settle_frozen() noexcept {
  if (!frozen_.open) return;
  lost_ += missing_while_frozen(frozen_);
  frozen_ = {};
}

// Refused frames over half a counter turn or more since the last good one (a wrong CRC for a
// second): the values they carried repeat, so they cannot tell which skipped values were lost on the
// bus. The counter says how many frames were sent in between modulo its turn; the time since the last
// good frame, at the learned period, says which turn. Only while frames kept arriving (no silence of
// half a turn: a stalled or restarted ECU sends nothing, and frames never sent are not lost). Told by
// the values instead, a bus loss of one frame in ten over a one-second wrong-CRC run went uncounted
// (ten-minute campaign, seed 3: 17 feedback frames neither published nor counted lost). -1: not such
// a run.
long long FrameLossCounter::sent_across_refused_run(int skipped, Nanos now, double silence_room, int modulus) const noexcept {
  if (period_ns_ <= 0 || arrivals_since_good_ == 0 || silence_room > modulus / 2.0) return -1;
  const double by_time = slots_since_good(now);
  if (by_time < modulus / 2.0) return -1;  // within half a turn the values tell (above)
  const auto turns = std::llround((by_time - skipped) / modulus);
  const long long sent = skipped + std::max<long long>(0, turns) * modulus;
  return std::max<long long>(sent, static_cast<long long>(arrivals_since_good_));
}

// The period from back-to-back good frames only: their mean interval. A frozen run is counted in
// periods over its whole span (50 at 100 Hz for half a second), so the period must be exact to a
// fraction of a percent: an exponential average of jittery intervals (a 1 ms-tick sender) was ~1 %
// off at times, a frame too many over such a run. Halved when long, so drift is followed. Nor the
// short intervals of a burst after a network hold, nor its long interval: taken, ten holds
// shortened the period enough for a frame too many over a frozen second.
// Which intervals are plausible is told by the median of the latest ones, never by the mean itself:
// judged by itself, the mean kept whatever its first interval said. A bridge that started with
// frames queued, or was late with its first, learned 2.15 ms for a 10 ms message and kept it: each
// frozen or refused run of a second was then 466 periods, 366 frames counted lost that were not
// (whole-rig campaign seed 25, 1 run in 8: "the rig counted 907 can_frames lost, 221 were not
// published"). A mean that strays from the median by a quarter starts anew.
void FrameLossCounter::learn_period(Nanos interval) noexcept {
  recent_[recent_next_] = interval;
  recent_next_ = (recent_next_ + 1) % recent_.size();
  recent_n_ = std::min(recent_n_ + 1, recent_.size());
  if (recent_n_ < kMinRecent) return;
  // Taken anew every few intervals: it moves slowly, and a median per frame cost 6x the rest.
  if (median_ns_ == 0 || recent_next_ % kMedianEvery == 0) {
    std::array<Nanos, kRecent> sorted{};
    std::copy_n(recent_.begin(), recent_n_, sorted.begin());
    const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(recent_n_ / 2);
    std::nth_element(sorted.begin(), mid, sorted.begin() + static_cast<std::ptrdiff_t>(recent_n_));
    median_ns_ = static_cast<double>(*mid);
  }
  const double median = median_ns_;
  const auto x = static_cast<double>(interval);
  if (intervals_ > 0 && std::abs(period_ns_ - median) > median / 4) {
    interval_sum_ns_ = 0;
    intervals_ = 0;
  }
  if (2 * x > median && 2 * x < 3 * median) {
    interval_sum_ns_ += x;
    if (++intervals_ > 4096) {
      interval_sum_ns_ /= 2;
      intervals_ /= 2;
    }
  }
  period_ns_ = intervals_ > 0 ? interval_sum_ns_ / static_cast<double>(intervals_) : median;
}

void FrameLossCounter::on_frame(std::span<const std::uint8_t> payload, safety::E2eStatus st, Nanos now) noexcept {
  using safety::E2eStatus;
  if (!countable()) return;
  const Nanos silence = have_last_ ? now - last_arrival_ : 0;
  longest_silence_ = std::max(longest_silence_, silence);
  last_arrival_ = now;
  const bool after_frozen = last_repeated_;
  last_repeated_ = st == E2eStatus::kRepeated;
  const int modulus = safety::counter_modulus(c_.profile);
  if (!safety::is_ok(st)) {
    settle_frozen();
    ++arrivals_since_good_;
    if (period_ns_ > 0)  // the k-th refused frame after the last good one: sent k periods after it at least
      pull_back_send_estimate(last_good_sent_by_, now, static_cast<double>(arrivals_since_good_), period_ns_);
    ++lost_;
    refused_since_ = true;
    // The value it carried (readable unless the layout is wrong): a position on the counter that is
    // not a loss on the bus.
    if (st != E2eStatus::kBadLayout) {
      const std::uint8_t v = safety::read_counter(c_, payload);
      if (v < modulus) refused_values_ |= 1U << v;
      // The value of the frame before it again: the counter stood still inside the run.
      if (v == (arrivals_since_good_ > 1 ? last_refused_value_ : last_counter_)) stood_still_in_run_ = true;
      last_refused_value_ = v;
    }
    return;
  }
  const std::uint8_t counter = safety::read_counter(c_, payload);
  if (have_last_) {
    const int skipped = (counter - last_counter_ - 1 + 2 * modulus) % modulus;
    if (frozen_.open) {
      // A good frame in sequence after a frozen run: it was sent good_after periods after the run's
      // first good frame.
      if (skipped == 0 && !refused_since_) {
        ++frozen_.good_after;
        pull_back_send_estimate(frozen_.end, now, frozen_.good_after, frozen_.period_ns);
        if (frozen_.good_after >= kSettleFrames) settle_frozen();
      } else {
        settle_frozen();
      }
    }
    int on_bus = 0;  // skipped values no refused frame carried: lost on the bus
    for (int k = 1; k <= skipped; ++k)
      if ((refused_values_ & (1U << ((last_counter_ + k) % modulus))) == 0) ++on_bus;
    // Frames a silence between two arrivals had room for, at the learned period.
    const double room = period_ns_ > 0 ? static_cast<double>(longest_silence_) / period_ns_ - 1.0 : 0.0;
    // A frozen run's refused frames repeat one value; a run whose values differ went on counting (a
    // wrong-CRC run of a counter turn less one ends on the value it began after, as a frozen one does).
    const bool frozen_run = after_frozen && std::popcount(refused_values_) <= 1;
    // A run whose values counted on and then stood still (a frozen counter beginning inside a
    // wrong-CRC run) says neither by its values: the jump and a turn by time were off by up to half a
    // turn (ten-minute campaign, seed 4: 6 frames counted lost that were published). Time alone.
    // Within half a turn the values still tell (each refused one counted as it came, the skipped
    // values no refused frame carried lost on the bus).
    const bool stood_still_inside = stood_still_in_run_ && !frozen_run && period_ns_ > 0 && slots_since_good(now) >= modulus / 2.0;
    if ((skipped == 0 && frozen_run) || stood_still_inside) {
      // The first good frame after a frozen run: only time can tell (settled by the frames after it).
      if (period_ns_ > 0) frozen_ = {true, last_good_sent_by_, now, arrivals_since_good_, longest_silence_, period_ns_, 0};
    } else if (const auto sent = frozen_run ? -1 : sent_across_refused_run(skipped, now, room, modulus); sent >= 0) {
      lost_ += static_cast<std::uint64_t>(sent) - arrivals_since_good_;  // the refused ones counted as they came
    } else if (on_bus > 0 && room > modulus - 1.5) {
      // A silence with room for a whole counter turn: k lost or k + a turn, or an ECU that restarted
      // (its counter anew: frames never sent are not lost). Not guessed. Below a turn the jump can only
      // be k: a hold of the network (50 ms) and three frames lost after it are a silence of 9 periods,
      // which half a turn (7.5) took for unknown (ten-minute campaign, seed 3, 295.7 s: 3 frames
      // "neither published nor counted lost"). An ECU does not restart in less (the mock's take 1 s).
      ++gaps_unknown_;
    } else {
      lost_ += static_cast<std::uint64_t>(on_bus);
    }
    if (skipped == 0 && !refused_since_ && longest_silence_ > 0) learn_period(longest_silence_);
  }
  have_last_ = true;
  last_good_arrival_ = now;
  last_good_sent_by_ = now;
  arrivals_since_good_ = 0;
  last_counter_ = counter;
  longest_silence_ = 0;
  refused_values_ = 0;
  refused_since_ = false;
  stood_still_in_run_ = false;
}

}  // namespace sensor_rig::dbw
