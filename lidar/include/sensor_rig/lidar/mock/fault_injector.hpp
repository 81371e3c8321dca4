#pragma once
// Network faults for mock sensors (there is no tc netem on the target machines): random drop,
// byte corruption, truncation, duplication, reordering and periodic stalls, reproducible from a
// seed. Pure: packets and their schedule offsets in, packets to send out; no I/O, no clock.
#include <cstddef>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar::mock {

struct FaultConfig {
  double drop_rate = 0.0;       // probability a packet is not sent
  double corrupt_rate = 0.0;    // probability 1..4 bytes are XOR-ed with random non-zero values
  double truncate_rate = 0.0;   // probability the datagram is cut to a random shorter length
  double duplicate_rate = 0.0;  // probability the packet is sent twice
  double reorder_rate = 0.0;    // probability the packet is held back and sent after the next one
  Nanos stall_ns = 0;           // a gap of this length ...
  Nanos stall_every_ns = 0;     // ... every this much stream time (both > 0 to enable)
  std::uint64_t seed = 1;

  // Throws std::invalid_argument naming the option (rates must be in [0, 1], durations >= 0).
  void validate() const;
  [[nodiscard]] bool any() const noexcept;
};

struct FaultStats {
  std::uint64_t dropped = 0;
  std::uint64_t corrupted = 0;
  std::uint64_t truncated = 0;
  std::uint64_t duplicated = 0;
  std::uint64_t reordered = 0;
  std::uint64_t stalls = 0;
  Nanos stalled_ns = 0;  // total delay added by stalls
};

struct FaultedPacket {
  Nanos offset_ns = 0;               // when to send, relative to the stream start
  std::span<const std::byte> bytes;  // valid until the next push() / flush()
  bool position = false;
  std::int64_t tag = -1;             // the truth record's part (StreamPacket::tag)
};

class FaultInjector {
 public:
  explicit FaultInjector(const FaultConfig& config, std::size_t max_packet_bytes = 65536);

  // One packet in (offset relative to the stream start); 0..3 packets out, in send order.
  std::span<const FaultedPacket> push(Nanos offset_ns, std::span<const std::byte> bytes, bool position,
                                      std::int64_t tag = -1);
  // Releases a packet still held back for reordering (call at the end of the stream).
  std::span<const FaultedPacket> flush();

  [[nodiscard]] const FaultStats& stats() const noexcept { return stats_; }

 private:
  bool chance(double p) noexcept;

  FaultConfig cfg_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  FaultStats stats_;
  Nanos delay_ns_ = 0;        // accumulated stall delay
  Nanos next_stall_ns_ = 0;
  Nanos last_when_ = 0;       // schedule of the last packet pushed
  std::vector<std::byte> cur_, held_, released_;
  bool have_held_ = false;
  bool held_position_ = false;
  std::int64_t held_tag_ = -1;
  FaultedPacket out_[3];
};

}  // namespace sensor_rig::lidar::mock
