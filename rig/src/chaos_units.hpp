#pragma once
// The judge's view of a truth record (chaos_check.cpp): each unit a device made, with what became
// of its parts (lost, damaged, late, never sent, never made), and the vehicle time the faults made
// special (read twice after a clock step, held by netem). Pure functions of the truth.
#include <cstdint>
#include <vector>

#include "sample_record.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::rig::chaos {

inline constexpr Nanos kSecond = 1'000'000'000;

// One unit of the truth with what became of its parts.
struct UnitTruth {
  truth::UnitRecord rec;
  std::uint32_t produced = 0;  // parts the device produced (everything but not_sent)
  std::uint32_t lost = 0;      // dropped on the way
  std::uint64_t lost_fault = 0;  // the fault its dropped parts name (the last one's; 0 = none)
  std::uint32_t damaged = 0;   // corrupted or truncated
  // Parts reordered (delayed) past every other part of their unit: the rig may have published the
  // unit before they came (a scan ends at its last packet or the next scan's first), so it may count
  // them missing: the sample lacks them. A late packet is placed or counted, but not in the past.
  std::uint32_t late = 0;
  Nanos last_tx = 0;           // the latest send of its parts that were not delayed
  std::vector<Nanos> delayed_tx;
  Nanos first_intact_acq = 0;  // the earliest part that arrived as rendered (0 = none)
  // The send of its first-fired part that went out in its turn (not delayed, not dropped): a scan's
  // first packet arrives just after it. Its first part, not its earliest send: a clock step back
  // inside the unit makes a later part's send read earlier.
  Nanos first_tx = 0;
  Nanos first_sent_acq = 0;
  // The same for its first part sent in its turn as rendered: where its first parts were corrupted
  // (lidar.stuck_azimuth, lidar.corrupt), the rig drops them and its scan begins at this one.
  Nanos first_intact_tx = 0;
  Nanos first_intact_sent_acq = 0;
  // Parts the device did not send (a blind sector, a restart), and of those the ones a rig may count
  // missing: a blind arc new this turn (new_blind_arcs). A part across a scan cut is in both.
  // Nothing in a LIDAR's packets tells the first turn of a new blind sector from a loss burst at the
  // same place (no packet sequence on these models: the received stream is the same), so counting it
  // missing is the honest reading; the same arc a second turn in a row is the sensor's, not loss.
  std::uint32_t not_sent = 0;
  std::uint32_t new_blind = 0;
  // A unit whose mock was killed before its line was written (host.kill_mock mid-scan): the parts
  // it never made the rig may count missing (nothing in the stream tells a kill from a loss), up to
  // a whole unit's parts. Its acquisition is known only to lie in its first part, which may be the
  // previous unit's last packet across the cut: up to its own first part (`own_first_acq`).
  bool has_line = true;
  Nanos own_first_acq = 0;
  std::uint32_t never_made = 0;
  const SampleRecord* sample = nullptr;
};

// A run of parts not sent: log.parts[first..last], consecutive in the device's order.
struct NotSentRun {
  std::size_t first = 0, last = 0;
};
// The runs that are a new blind arc, not the same arc as a turn earlier (a rig may count those
// missing: see UnitTruth::not_sent).
std::vector<NotSentRun> new_blind_arcs(const truth::Log& log);

struct Interval {
  Nanos begin, end;
};

// Loopback delays by netem (host.network_delay "via=netem"): a part sent then arrives `delay` after
// its send in the truth (the mock hands it to the socket; the kernel holds it). The LIDAR mocks'
// own hold needs none: their truth's send is the held one.
struct HeldInterval {
  Nanos begin, end, delay;
};

// The units of one truth record in acquisition order, with their parts' fates: units whose line
// is missing (a killed mock) rebuilt from their parts, a new blind arc told from last turn's.
std::vector<UnitTruth> units_of(const truth::Log& log);

// How far a sample may lie from its unit: half the median unit spacing (at least 1 ms).
Nanos match_tolerance(const std::vector<UnitTruth>& units);

// Vehicle time that happened twice: a clock step back (or the return of a step forward) makes the
// host's CLOCK_REALTIME read the same values again. A stamp in such a range names two instants, so
// units and samples there are left out of the stamp-matched counts rather than matched by luck.
std::vector<Interval> doubled_vehicle_time(const std::vector<truth::Log>& truths);

std::vector<HeldInterval> netem_delays(const std::vector<truth::Log>& truths);

// Each host clock step back (a host.clock_step back, or the return of one forward) and the time its
// slew may run: a node holds a step back and slews it out at 10 % of the elapsed time, its stamps
// late by at most the step meanwhile (timesync/README.md "Realtime steps"). [begin, end) spans the
// step time in the clock before and after it, and the 10 steps' lengths of slew after it.
struct SlewSpan {
  Nanos begin, end, step;
};
std::vector<SlewSpan> slews_after_steps_back(const std::vector<truth::Log>& truths);
// How late a stamp at t may be by those slews: the steps whose slew may still run at t, summed.
Nanos slew_bound(const std::vector<SlewSpan>& slews, Nanos t);

// What a LIDAR's `scans_unheard` may cover (lidar/include/sensor_rig/lidar/stream_gap.hpp): its
// units in [begin, end) neither published nor with one part that reached the rig, inside a stretch
// longer than lidar::kSilenceTurns of their turns in which nothing at all did (a loss burst that
// long, which a model without numbering cannot tell from a silent sensor), and the turns the device
// made nothing in there (its mock killed or restarting: gaps between its units' acquisitions of more
// than one and a half turns). `units` in acquisition order, matched to their samples.
struct Unheard {
  std::uint64_t units = 0;        // made, lost whole in a silence: an honest `unheard` covers them
  std::uint64_t turns_unmade = 0;  // no unit made: an honest `unheard` may have them, no more
};
Unheard unheard_of(const truth::Log& log, const std::vector<UnitTruth>& units, Nanos begin, Nanos end);

// Slots of a CAN message's period in which the ECU made no frame while its alive counter stood still
// (dbw.stuck_counter), the later frame of each such silence in [begin, end). On the bus a silent slot
// and a frame lost there are the same: a frozen counter shows no jump, only the period shows the gap,
// so the rig's count may have them (FrameLossCounter counts a frozen run's room at its learned period).
// A mock ECU late by a period on a loaded host skips a slot (it starts a new grid rather than burst):
// whole-rig campaign seed 25, "the rig counted 241 can_frames lost, 240 were not published".
std::uint64_t slots_skipped_while_frozen(const truth::Log& log, Nanos begin, Nanos end);

}  // namespace sensor_rig::rig::chaos
