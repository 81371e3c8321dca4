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
// received stream is the same): its turns go uncounted. lidar/README.md "Silences".
#include <cstdint>

#include "sensor_rig/lidar/packet.hpp"

namespace sensor_rig::lidar {

// Nothing heard for longer than this many turns (rotations, Ouster frames): a silence.
inline constexpr Nanos kSilenceTurns = 3;

// What the sensor's own numbering says across a gap.
enum class IdsAcrossGap : std::uint8_t {
  kNone,       // the model numbers nothing (Velodyne, a Pandar40P without UDP sequence)
  kContinued,  // numbered on as its time says: its packets were sent (and lost)
  kRestarted,  // numbered otherwise: begun again (a restart)
};

// The host's side of the rule: when the decoder last heard the sensor.
class StreamGap {
 public:
  // Every packet the decoder is handed, kept or rejected (DecoderPimpl::push, after decoding it).
  void heard(Nanos rx_ns) noexcept {
    last_rx_ = rx_ns;
    heard_ = true;
  }
  void forget() noexcept { heard_ = false; }

  // How long nothing was heard before a packet received at `rx_ns` (0: nothing heard yet). A
  // decoder asks is_silence() only when this exceeds kSilenceTurns packets (a cheap first test: a
  // turn is many packets), so the hot path pays one subtraction per packet.
  [[nodiscard]] Nanos quiet_ns(Nanos rx_ns) const noexcept { return heard_ ? rx_ns - last_rx_ : 0; }

 private:
  Nanos last_rx_ = 0;
  bool heard_ = false;
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
