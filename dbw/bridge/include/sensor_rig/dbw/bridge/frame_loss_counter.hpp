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
// room for at the message's learned period, less those that arrived, are counted when it ends.
// Refused frames over half a counter turn (a wrong CRC for a second) carry every value many times: the
// frames sent across such a run are told by the counter modulo its turn and the time for the turn.
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

  [[nodiscard]] std::uint64_t lost() const noexcept { return lost_; }
  [[nodiscard]] std::uint64_t gaps_unknown() const noexcept { return gaps_unknown_; }
  // False for a message without a counter: its losses cannot be seen.
  [[nodiscard]] bool countable() const noexcept { return c_.profile != safety::E2eProfile::kNone; }

 private:
  [[nodiscard]] double slots_since_good(Nanos now) const noexcept;
  [[nodiscard]] std::uint64_t missing_while_frozen(Nanos now) const noexcept;
  [[nodiscard]] long long sent_across_refused_run(int skipped, Nanos now, double silence_room, int modulus) const noexcept;

  safety::E2eConfig c_;
  bool have_last_ = false;
  Nanos last_good_arrival_ = 0;
  std::uint64_t arrivals_since_good_ = 0;  // frames of the message (all refused) since the last good one
  std::uint8_t last_counter_ = 0;      // of the last good frame
  Nanos last_arrival_ = 0;             // of any frame of the message
  Nanos longest_silence_ = 0;          // between arrivals since the last good frame
  std::uint32_t refused_values_ = 0;   // bit per counter value the refused frames since then carried
  bool refused_since_ = false;
  bool last_repeated_ = false;         // the last frame repeated its predecessor's counter
  double period_ns_ = 0;               // the message's period, learned from consecutive good frames
  double interval_sum_ns_ = 0;         // ... as their mean interval
  std::uint64_t intervals_ = 0;
  std::uint64_t lost_ = 0;
  std::uint64_t gaps_unknown_ = 0;
};

}  // namespace sensor_rig::dbw
