#pragma once
// A gap in a LIDAR's packet stream: packets lost on the way, or a sensor that sent nothing
// (issue 26). One rule for every vendor decoder, applied before order, time and loss are judged.
//
// A sensor that is off, restarting or cut off from the host makes no scans we could lose: the
// monitor's count of lost scans must not grow while it is silent (lidar_driver.cpp: `scans_lost`;
// `rig chaos` holds the rig's count against the scans the sensor made). Lost packets are another
// matter: their turns were made and must be counted. What a decoder can tell them by:
//   - the host's receive times: nothing at all arrived (no packet, kept or rejected: a frozen
//     azimuth or a corrupt time still shows the sensor sending) for longer than kSilenceTurns
//     turns, while the sensor's own time says more than the next packet (or went back: a reset
//     clock). A burst lost in a network lasts milliseconds; a silence that long is the sensor's.
//   - the sensor's own numbering across the gap, where the model has one (Hesai UDP sequence,
//     Ouster frame id): counted on as the time says, the sensor sent what we did not get (loss,
//     however long: its turns are counted); begun again, it restarted (a new stream).
// A silence ends the scan in progress as partial (discarded and counted lost: the sensor made it
// but not whole; so are the scans begun by packets rejected since the last kept one,
// scans_begun_while_rejected) and starts a new stream: no packets missing, no turns lost, nothing before it
// taken for a late or duplicate packet (a restarted Pandar40P's first 15 packets were dropped as
// out of order: its azimuth lay just behind the last one heard a second before).
// Without numbering, a loss burst longer than the silence bound is taken for a silence (the
// received stream is the same): its whole turns are counted unheard (scans_unheard), lost or never
// made, never lost alone (a killed sensor made none) nor nothing (a VLP-32C at 900 rpm lost 3.07
// turns of packets: 2 of its 4 scans were counted nowhere, rig chaos seed 9). lidar/README.md
// "Silences".
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/packet_time.hpp"

namespace sensor_rig::lidar {

// Nothing heard for longer than this many turns (rotations, Ouster frames): a silence.
inline constexpr Nanos kSilenceTurns = 3;

// What the sensor's own numbering says across a gap.
enum class IdsAcrossGap : std::uint8_t {
  kNone,       // the model numbers nothing (Velodyne, a Pandar40P without UDP sequence)
  kContinued,  // numbered on as its time says: its packets were sent (and lost)
  kRestarted,  // numbered otherwise: begun again (a restart)
};

// The host's side of the rule: when the decoder last heard the sensor, and the silence before a
// packet rejected whole (a restarted sensor whose encoder is frozen: rig chaos seed 4, the left
// OS-LEGACY's restart then stuck azimuth). Such a packet is heard (the sensor sends again), but no
// decoder can judge a silence by it (no azimuth or ids to place it by): the silence is kept for the
// next kept packet, which judges it, and the packets rejected after it are told apart from those
// rejected before (their turns are the new stream's).
class StreamGap {
 public:
  // Every packet the decoder is handed, kept or rejected (DecoderPimpl::push, after decoding it),
  // with the decoder's count of packets rejected since the last kept one before and after it: a
  // rise is a packet rejected whole, a fall to 0 (or less than before) a kept packet.
  void heard(RxTimes rx, std::uint32_t rejected_before, std::uint32_t rejected_after) noexcept {
    const Nanos quiet = quiet_before(rx);
    if (rejected_after > rejected_before) {
      if (quiet > pending_quiet_) {
        pending_quiet_ = quiet;
        rejected_before_quiet_ = rejected_before;
      }
    } else if (rejected_after == 0 || rejected_after < rejected_before) {
      pending_quiet_ = 0;
      rejected_before_quiet_ = 0;
    }
    last_rx_ = rx;
    heard_ = true;
  }
  void forget() noexcept {
    heard_ = false;
    pending_quiet_ = 0;
    rejected_before_quiet_ = 0;
  }

  // How long nothing was heard before a packet received at `rx`, or before the packets rejected
  // whole since the last kept one if that was longer (0: nothing heard yet). A decoder asks
  // is_silence() only when this exceeds kSilenceTurns packets (a cheap first test: a turn is many
  // packets), so the hot path pays a subtraction and a comparison per packet.
  // Measured on CLOCK_MONOTONIC where known (receive_gap): a host clock step forward is no silence
  // (a VLP frozen 0.25 s under a +37 s step was taken for a silent sensor, a turn counted twice).
  [[nodiscard]] Nanos quiet_ns(RxTimes rx) const noexcept { return std::max(quiet_before(rx), pending_quiet_); }

  // Of the `rejected` packets rejected whole since the last kept one, those the sensor sent before
  // the silence quiet_ns() measured (the rest came after it: the new stream's).
  [[nodiscard]] std::uint32_t rejected_before_silence(RxTimes rx, std::uint32_t rejected) const noexcept {
    return pending_quiet_ > quiet_before(rx) ? std::min(rejected, rejected_before_quiet_) : rejected;
  }

 private:
  // -1 when not known (CLOCK_REALTIME stepped back between the two, no monotonic times): no silence.
  [[nodiscard]] Nanos quiet_before(RxTimes rx) const noexcept { return heard_ ? receive_gap(rx, last_rx_) : 0; }

  RxTimes last_rx_;
  bool heard_ = false;
  Nanos pending_quiet_ = 0;                // the longest quiet before a packet rejected since the last kept one
  std::uint32_t rejected_before_quiet_ = 0;  // packets rejected before that quiet
};

// The gap after `quiet_ns` of nothing heard is a silence: longer than kSilenceTurns turns of
// `turn_ns` (0 or less: unknown, never a silence), the sensor's time not the next packet's
// (`sensor_continues`: a stalled sender's late packets are no silence), and no numbering that says
// the sensor went on sending.
[[nodiscard]] constexpr bool is_silence(Nanos quiet_ns, Nanos turn_ns, bool sensor_continues,
                                        IdsAcrossGap ids) noexcept {
  if (turn_ns <= 0 || quiet_ns <= kSilenceTurns * turn_ns) return false;
  return !sensor_continues && ids != IdsAcrossGap::kContinued;
}

// Whole scans a silence lay over, none of whose packets came (a model without numbering: a
// loss burst or a silent sensor, the decoder cannot tell). The sensor turned `elapsed_ns` (its
// time's step, or the host's where that went back) from the last group heard to the first after
// the silence, `arc` forward of it (0.01°, the azimuth's step), and met the cut first `to_cut`
// ahead (0.01°, in (0, kTurn]): the cuts it crossed up to the first group, less the one that ended
// the scan in progress (counted lost, partial). A first group at a cut opens its scan whole.
[[nodiscard]] inline std::uint64_t scans_unheard(Nanos elapsed_ns, Nanos turn_ns, int arc, int to_cut) noexcept {
  constexpr double kTurn = 36000.0;
  if (turn_ns <= 0 || elapsed_ns <= 0 || to_cut <= 0) return 0;
  const double along = static_cast<double>(arc) / kTurn;
  const double whole = std::max(0.0, std::round(static_cast<double>(elapsed_ns) / static_cast<double>(turn_ns) - along));
  const double travel = whole + along;  // turns from the last group heard to the first after
  const double first_cut = static_cast<double>(to_cut) / kTurn;
  if (first_cut > travel) return 0;
  return static_cast<std::uint64_t>(std::floor(travel - first_cut));  // cuts crossed, less the first
}

// The time a silence lasted as the sensor turned: its own time's step where that went forward and
// no farther than the host heard nothing for (and a turn), else the host's.
[[nodiscard]] constexpr Nanos silence_elapsed(Nanos sensor_step_ns, Nanos quiet_ns, Nanos turn_ns) noexcept {
  return sensor_step_ns > 0 && sensor_step_ns <= quiet_ns + turn_ns ? sensor_step_ns : quiet_ns;
}

// How much later than usual the last packet kept arrived: the receive times' step less the sensor's
// own, summed over the steps between kept packets, above its least (the floor). A network that held
// the stream (host.network_delay, a switch's queue) delivers it late by the hold, then drains at link
// rate: the packets queued behind come microseconds apart, though sent a packet period (or a blind
// sector) apart. The floor falls at once and rises by at most 1 ms a second (the sensor's clock
// drifting from the host's), so a hold of seconds stays a hold. Reset where the stream begins again.
class ArrivalLateness {
 public:
  // A kept packet `sensor_step_ns` after the previous kept one by the sensor's time (as loss counts
  // it), `rx_gap_ns` by the host's (receive_gap; -1: not known, the lateness starts again).
  void step(Nanos sensor_step_ns, Nanos rx_gap_ns) noexcept {
    if (rx_gap_ns < 0) {
      reset();
      return;
    }
    late_ += rx_gap_ns - std::max<Nanos>(0, sensor_step_ns);
    floor_ = std::min(late_, floor_ + rx_gap_ns / kFloorRiseDivisor);
  }
  void reset() noexcept { late_ = floor_ = 0; }
  // How late the last kept packet came beyond the floor (capped: no queue holds a sensor longer).
  [[nodiscard]] Nanos above_floor() const noexcept { return std::min(late_ - floor_, kMostHeldNs); }

 private:
  static constexpr Nanos kFloorRiseDivisor = 1000;      // 1 ms a second
  static constexpr Nanos kMostHeldNs = 2'000'000'000;  // beyond, a silence's or a clock's doing
  Nanos late_ = 0, floor_ = 0;
};

// The sensor's time step between two packets as loss may count it: no more than twice their
// receive times' step (a held network brings two packets closer by at most half their interval,
// common/network_hold.hpp, while it holds) plus how late the earlier one came (`late_ns`,
// ArrivalLateness::above_floor: the queue behind a hold drains at once, by up to that much; rig
// chaos seed 9, ten minutes: a VLP-32C's 121 ms hold drained inside a blind sector, the sector's
// gap taken for an implausible azimuth, a scan counted lost though 24 of its packets came, 105
// phantom packets beside it; ScanFaults.ANetworkHoldAroundAWideBlindSectorLosesNothing). One
// corrupt time byte otherwise made its step to the next packet's a count of turns and packets lost:
// "66,033,013,710 scans lost" by an OS-LEGACY (rig chaos seed 25, a drawn lidar.corrupt
// field=time), 15,269 scans and 1,000,000 packets by a VLP-32C
// (ScanFaults.OneCorruptedTimeAtAScansStartCountsNoPhantomScans). The receive step is receive_gap's
// (CLOCK_MONOTONIC where known); unknown or stepped back: the sensor's step as it is.
[[nodiscard]] constexpr std::int64_t sensor_step_within_receive(std::int64_t sensor_step_ns, RxTimes rx, RxTimes prev_rx,
                                                                Nanos late_ns = 0) noexcept {
  const Nanos gap = receive_gap(rx, prev_rx);
  return gap < 0 ? sensor_step_ns : std::min<std::int64_t>(sensor_step_ns, 2 * gap + std::max<Nanos>(0, late_ns));
}

// The sensor's time from one packet to the next is that of a packet or two later (with half a
// packet of jitter): the stream went on, only the host heard nothing for a while.
[[nodiscard]] constexpr bool sensor_continues(Nanos dt_ns, Nanos packet_period_ns) noexcept {
  return dt_ns > 0 && dt_ns <= 2 * packet_period_ns + packet_period_ns / 2;
}

// Scans begun by the packets rejected whole after the last kept one (a frozen encoder, no column
// ids) when a silence comes next. Each was sent in its place of the stream (ScanAssembler::
// rejected_since_kept), so every cut they crossed began a scan the sensor made and the host never
// got. A good packet after them shows those turns (the azimuth or frame step); before a silence
// there is none, and the silence ends the scan in progress only (rig chaos seed 5: a VLP-32C's
// azimuth stuck, then its mock killed: 4 scans made, 1 counted lost, 3 unaccounted). So they go by
// their number: the first to begin a scan is the `first_new`th after the last kept one (the first
// whose firings reach the cut), then one every `per_turn` (packets a turn).
[[nodiscard]] constexpr std::uint64_t scans_begun_while_rejected(std::uint32_t rejected, double first_new,
                                                                 double per_turn) noexcept {
  if (rejected == 0 || !(per_turn >= 1.0)) return 0;
  const double first = first_new < 1.0 ? 1.0 : first_new;
  if (static_cast<double>(rejected) < first) return 0;
  return 1 + static_cast<std::uint64_t>((static_cast<double>(rejected) - first) / per_turn);
}

// Scans the packets rejected whole after a silence (a restarted sensor, its encoder frozen) began
// and ended before the first kept packet of the new stream: one for every cut between the first of
// them and that packet. Counted back from that packet: the `back` packets before it in its own turn
// are its scan's (the decoder ends that one partial); the rest lie in earlier turns, one a
// `per_turn`. The count of scans_begun_while_rejected, read backwards.
[[nodiscard]] constexpr std::uint64_t scans_ended_while_rejected(std::uint32_t rejected, double back,
                                                                 double per_turn) noexcept {
  return scans_begun_while_rejected(rejected, (back < 0.0 ? 0.0 : back) + 1.0, per_turn);
}

// A counter across a gap (UDP sequence, frame id; `mask`: its width) against the count the sensor
// time says passed (`by_time`): on, within one and 1/64 of the count, or begun again.
[[nodiscard]] constexpr IdsAcrossGap ids_across_gap(std::uint32_t prev, std::uint32_t now, std::uint32_t mask,
                                                    std::int64_t by_time) noexcept {
  const auto step = static_cast<std::int64_t>((now - prev) & mask);
  const std::int64_t d = step - by_time;
  const std::int64_t slack = 1 + (by_time > 0 ? by_time / 64 : 0);
  return d >= -slack && d <= slack ? IdsAcrossGap::kContinued : IdsAcrossGap::kRestarted;
}

}  // namespace sensor_rig::lidar
