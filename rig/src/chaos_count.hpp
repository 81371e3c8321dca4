#pragma once
// The rig's own count of lost units (counted_lost) held against the units it did not publish
// (chaos_check.cpp). The count can be matched to units by number only: it is the difference of two
// once-a-second monitor lines, and in vehicle time the host clock read twice its units have no
// stamp that names them alone.
#include <cstdint>

namespace sensor_rig::rig::chaos {

struct CountFacts {
  std::uint64_t rig_counted = 0;    // units the rig counted lost in the window
  std::uint64_t not_published = 0;  // judged units (in the window, not in doubled time) not published
  // Units not published within count_edge_ns of the window's edges, inside / outside it: the count's
  // window lies from the judged one by up to that (each monitor line is up to a diagnostics period
  // behind the losses it covers), so those may be in the count or not.
  std::uint64_t edge_in = 0, edge_out = 0;
  // Units made in vehicle time the host clock read twice (a step back), and samples published there.
  std::uint64_t doubled_made = 0, doubled_samples = 0;
  // Slots the device made nothing in that the rig cannot tell from a loss (a CAN message's frozen
  // alive counter: chaos_units.hpp slots_skipped_while_frozen): an honest count may have them.
  std::uint64_t silent_slots = 0;
  // Units the device lost where nothing tells the rig (a V4L2 frame done and gone with its device at
  // a disconnect, before it was dequeued: vb2 answers EIO before its done list): among
  // not_published, an honest count may have them or not.
  std::uint64_t unseeable = 0;
  // A LIDAR's turns it heard nothing in (its `unheard`, stream_gap.hpp: lost or never made, it cannot
  // tell), and what they may honestly be (chaos_units.hpp Unheard): units lost whole in a silence,
  // which they cover, and turns the device made nothing in, which they may hold besides.
  std::uint64_t rig_unheard = 0;
  std::uint64_t unheard_units = 0;
  std::uint64_t turns_unmade = 0;
};

struct CountVerdict {
  std::uint64_t doubled_lost = 0;     // units of doubled time not published: the count may cover them
  std::uint64_t most = 0;             // the most an honest count can be
  bool over_counted = false;          // the rig counted more than `most`: phantom loss
  std::uint64_t unaccounted_all = 0;  // losses neither published nor counted (doubled time's included)
  std::uint64_t unaccounted = 0;      // of the judged units: sent = published + counted_lost + unaccounted
  std::uint64_t counted_lost = 0;     // of the judged units, counted lost
  std::uint64_t counted_unheard = 0;  // of the judged units, covered by the rig's unheard turns
  bool over_unheard = false;          // more turns unheard than units lost whole there and turns unmade
};

// An honest count lies in [not_published - edge_in - unseeable + doubled_lost, not_published +
// edge_out + doubled_lost + silent_slots]; below it the rest is unaccounted (judged units first),
// above it phantom. The rig's unheard turns cover as many units as were lost whole in silences;
// more than those and the turns nothing was made in are phantom too.
CountVerdict reconcile_count(const CountFacts& f);

}  // namespace sensor_rig::rig::chaos
