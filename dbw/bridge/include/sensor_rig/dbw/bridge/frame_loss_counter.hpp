#pragma once
// Frames of one protected ECU message that the bridge did not use: lost on the bus (a jump of the
// message's alive counter) or refused by the E2E check. These are the units a topic fed by that
// message (/vehicle/state from the feedback frames) is missing, counted by the rig itself, so that
// `rig monitor` and `rig chaos` can tell a counted loss from a silent one (docs/faults.md).
//
// A refused frame counts at once (a wrong CRC, a counter out of sequence or repeated). A frame lost on
// the bus counts when the next good frame shows the jump: the counter values skipped, less those the
// refused frames in between carried. A counter of N values cannot tell k lost frames from k + N, nor a
// loss from an ECU that was silent (bus-off, restart: frames never sent are not lost): a jump across a
// silence with room for a whole counter turn (less a frame and a half of jitter) is counted as
// `gaps_unknown`, never guessed.
// A frozen counter (the same value repeated) cannot show a loss either: the frames a frozen run had
// room for at the message's learned period, less those that arrived, are counted when it ends. Its
// end is when the first good frame after it was sent, not when it arrived: a network hold across the
// end delays that frame and the ones behind it, which then come in a burst (a queue released: 2
// frames too many in the test of it). The next kSettleFrames good frames tell: the
// least of (arrival - its place behind the first × period), taken only where it is more than half a
// period earlier than the estimate before (a hold, not a sender's jitter: that one walks, and its
// least was a frame too few). Until they came, lost() holds the estimate so far. Its start alike: a
// hold across it delays the last good frame before it, and the refused frames after that one tell
// (the k-th of them was sent k periods after it at the earliest, later if some were lost).
// Refused frames over half a counter turn (a wrong CRC for a second) carry every value many times: the
// frames sent across such a run are told by the counter modulo its turn and the time for the turn,
// unless the counter stood still inside it (a frozen counter beginning inside a wrong-CRC run): then
// by time alone, as a frozen run.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/safety/e2e.hpp"

namespace sensor_rig::dbw {

class FrameLossCounter {
 public:
  explicit FrameLossCounter(const safety::E2eConfig& c) noexcept : c_(c) {}

  // A frame of the message arrived at `now` (monotonic); `st` is what its E2E check said.
  void on_frame(std::span<const std::uint8_t> payload, safety::E2eStatus st, Nanos now) noexcept;
  // A frame the bridge used but could not hand on (its queue full, the write failed).
  void on_not_delivered() noexcept { ++lost_; }

  [[nodiscard]] std::uint64_t lost() const noexcept { return lost_ + (frozen_.open ? missing_while_frozen(frozen_) : 0); }
  [[nodiscard]] std::uint64_t gaps_unknown() const noexcept { return gaps_unknown_; }
  // False for a message without a counter: its losses cannot be seen.
  [[nodiscard]] bool countable() const noexcept { return c_.profile != safety::E2eProfile::kNone; }

 private:
  // A frozen run from the last good frame before it (`from`) to the send of the first good one
  // after it (`end`, the least estimate so far), with the frames that arrived in between.
  struct FrozenRun {
    bool open = false;
    Nanos from = 0;
    Nanos end = 0;
    std::uint64_t arrived = 0;
    Nanos longest_silence = 0;
    double period_ns = 0;  // the learned period when it ended (the count's, as the frames after it are placed by)
    int good_after = 0;    // good frames after the first one, each in sequence
  };
  static constexpr int kSettleFrames = 8;
  // The latest intervals between back-to-back good frames, whose median says which are plausible.
  static constexpr std::size_t kRecent = 31;
  static constexpr std::size_t kMinRecent = 9;  // no period before
  static constexpr std::size_t kMedianEvery = 8;  // intervals between two medians

  [[nodiscard]] double slots_since_good(Nanos now) const noexcept;
  [[nodiscard]] std::uint64_t missing_while_frozen(const FrozenRun& run) const noexcept;
  void settle_frozen() noexcept;
  void learn_period(Nanos interval) noexcept;
  [[nodiscard]] long long sent_across_refused_run(int skipped, Nanos now, double silence_room, int modulus) const noexcept;

  safety::E2eConfig c_;
  bool have_last_ = false;
  Nanos last_good_arrival_ = 0;
  Nanos last_good_sent_by_ = 0;        // ... or earlier, as the refused frames after it tell
  std::uint64_t arrivals_since_good_ = 0;  // frames of the message (all refused) since the last good one
  std::uint8_t last_counter_ = 0;      // of the last good frame
  Nanos last_arrival_ = 0;             // of any frame of the message
  Nanos longest_silence_ = 0;          // between arrivals since the last good frame
  std::uint32_t refused_values_ = 0;   // bit per counter value the refused frames since then carried
  std::uint8_t last_refused_value_ = 0;  // the value the last of them carried
  bool stood_still_in_run_ = false;      // one of them carried its predecessor's value (a frozen counter)
  bool refused_since_ = false;
  bool last_repeated_ = false;         // the last frame repeated its predecessor's counter
  double period_ns_ = 0;               // the message's period, learned from consecutive good frames
  double interval_sum_ns_ = 0;         // ... as their mean interval
  std::uint64_t intervals_ = 0;
  std::array<Nanos, kRecent> recent_{};
  std::size_t recent_n_ = 0;
  std::size_t recent_next_ = 0;
  double median_ns_ = 0;  // of recent_, taken every kMedianEvery intervals
  std::uint64_t lost_ = 0;
  std::uint64_t gaps_unknown_ = 0;
  FrozenRun frozen_;  // counted, not yet settled
};

}  // namespace sensor_rig::dbw
