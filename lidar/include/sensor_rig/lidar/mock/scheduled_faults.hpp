#pragma once
// The network's faults of the fault vocabulary, scheduled by time (rig chaos plans, `rig lidar
// replay --fault`): lidar.reorder (one packet n positions or ms late), lidar.duplicate_late (a copy
// n packets later), lidar.loss_burst (N consecutive data packets; at_cut=1: half before the scan
// cut, half after), lidar.corrupt (one packet with one field changed, packet_fields.hpp) and
// host.network_delay (every packet held back ms ± jitter_ms while it lasts, in order). Each decision
// is reported per tagged packet (the truth record's fates). Pure: packets and their schedule offsets
// in, packets out; no clock, no I/O. The rate-based faults stay in fault_injector.hpp.
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/network_hold.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/lidar/mock/packet_fields.hpp"

namespace sensor_rig::lidar::mock {

struct NetFault {
  enum class Kind : std::uint8_t { kReorder, kDuplicateLate, kLossBurst, kCorrupt, kDelay };
  std::uint64_t id = 0;  // the plan's event id
  Kind kind = Kind::kReorder;
  Nanos from_ns = 0;     // schedule offsets (as FaultedPacket::offset_ns)
  Nanos until_ns = 0;    // kDelay: the end; the one-packet faults act once, at the first data packet >= from_ns
  int n = 1;             // reorder / duplicate_late: positions
  Nanos hold_ns = 0;     // reorder: instead of positions, until a packet this much later
  int packets = 10;      // loss_burst
  bool at_cut = false;
  FieldBytes field;      // corrupt
  bool random_byte = false;
  Nanos delay_ns = 0;    // network_delay
  Nanos jitter_ns = 0;   // network_delay: each packet's hold within delay_ns ± this (never below 0), in order
};

struct NetPacket {
  Nanos offset_ns = 0;
  std::span<const std::byte> bytes;  // out: valid until the next push() / flush()
  bool position = false;
  std::int64_t tag = -1;             // the truth record's part, -1 = none
};

struct NetDecision {
  std::int64_t tag = -1;
  truth::Fate fate = truth::Fate::kSent;
  std::uint64_t fault = 0;
};

class ScheduledFaults {
 public:
  explicit ScheduledFaults(std::vector<NetFault> faults, std::uint64_t seed = 1);

  // One packet in; the packets that leave now, in order. `rotor_deg`: the data packet's first firing
  // in degrees past the scan cut (< 0: unknown, as in a capture; a loss at the cut is then a plain burst).
  std::span<const NetPacket> push(const NetPacket& in, double rotor_deg = -1.0);
  // Packets still held back (end of the stream).
  std::span<const NetPacket> flush();
  // Fates decided so far; the caller takes them (clear()).
  std::vector<NetDecision>& decisions() noexcept { return decisions_; }
  [[nodiscard]] bool empty() const noexcept { return faults_.empty(); }

 private:
  struct Held {
    std::vector<std::byte> bytes;
    bool position = false;
    std::int64_t tag = -1;
    int after = 0;          // data packets still to pass before it
    Nanos release_ns = -1;  // or: released by the first packet at/after this offset
  };
  void decide(std::int64_t tag, truth::Fate fate, std::uint64_t fault);
  std::span<std::byte> keep(std::span<const std::byte> bytes);
  void release(Nanos offset, bool force);

  std::vector<NetFault> faults_;
  std::vector<bool> done_;
  std::mt19937_64 rng_;
  std::mt19937_64 jitter_rng_;  // its own: a jitter changes no other fault's draws for a seed
  std::vector<faults::HoldWalk> walks_;  // a jittered delay's hold (common/network_hold.hpp)
  Nanos held_until_ = 0;  // the latest held packet's due offset: none after it leaves before it
  std::vector<Held> held_;
  std::vector<NetPacket> out_;
  std::vector<std::vector<std::byte>> store_;  // bytes of this call's copies (stable until the next call)
  std::size_t store_used_ = 0;
  std::vector<NetDecision> decisions_;
  const NetFault* burst_ = nullptr;  // the loss burst in progress
  int burst_left_ = 0;
  double last_rotor_ = -1.0;
};

}  // namespace sensor_rig::lidar::mock
