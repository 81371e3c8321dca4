#pragma once
// The order of a LIDAR packet against its predecessor: one rule for every vendor decoder (issue 26,
// "One judge, three vendors"). A vendor reports the packet's facts in its own terms (Velodyne and
// Hesai: block azimuths and the sensor time of the packet; Ouster: column times, measurement ids
// and frame id); the rule below decides, and ScanAssembler::drop() counts the verdict alike for
// every model (the same PacketStatus, the same `dropped`, the same implausible_steps).
// Judged before time and loss (after a silence, stream_gap.hpp): a late packet is placed or
// counted, never the end of its scan (item 1).
#include <cstdint>

namespace sensor_rig::lidar {

// What a vendor decoder knows of a packet that may be out of order.
struct OrderFacts {
  // Its position (azimuth, column ids or column times) lies behind the previous packet's, within
  // the reorder window: a duplicate, a late packet, or a frozen position.
  bool steps_back = false;
  // Its own time went on by more than half a packet (a time the judge of time did not reject):
  // a new packet whose position did not move, not an old one.
  bool time_moved_on = false;
  // Its position lies in the hole the current scan counted missing (LateHole), in the same frame,
  // and its time within the reorder window: the packet that hole lacks.
  bool fills_hole = false;
};

enum class Order : std::uint8_t {
  kNext,       // in order: judged on (time, loss, cut)
  kLate,       // placed in its scan's hole (missing back down, late_placed)
  kDuplicate,  // a copy or a packet too late for any hole: dropped (kOutOfOrder), takes no slot
  kFrozen,     // position back while its time went on: corrupt (kBadAzimuth), takes its slot
};

[[nodiscard]] constexpr Order judge_order(const OrderFacts& f) noexcept {
  if (!f.steps_back) return Order::kNext;
  if (f.time_moved_on) return Order::kFrozen;
  return f.fills_hole ? Order::kLate : Order::kDuplicate;
}

}  // namespace sensor_rig::lidar
