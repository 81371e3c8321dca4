#pragma once
// IPv4 fragment reassembly for the packet-ring source (an Ouster datagram is larger than a
// 1500-byte MTU, so the sensor's IP stack fragments it and a raw capture sees the pieces).
// Pure: IPv4 packets and their receive times in, whole datagrams out; no I/O, no clock.
// Bounded: at most max_in_flight datagrams of at most max_datagram_bytes, storage allocated once.
// Every datagram given up is counted once, by reason; its later fragments are swallowed until the
// timeout (not counted again). Exact duplicate fragments are ignored (counted as duplicates), also
// when they come after their datagram completed (within the timeout; the last `remember_completed`
// datagrams are remembered): before, such a copy opened a datagram of its own that expired as a
// `timeout` (issue 26 item 7).
// Two clocks: `rx_ns` (the kernel's receive stamp, CLOCK_REALTIME) is what a datagram is stamped
// with; `age_ns` (CLOCK_MONOTONIC) is what the timeout is measured on, so a host clock step neither
// gives up datagrams in flight (a step forward) nor keeps dead ones for the step's length (back).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar {

struct Ipv4ReassemblerConfig {
  std::size_t max_in_flight = 32;          // datagrams being reassembled at once
  std::size_t max_datagram_bytes = 65535;  // whole datagram, IPv4 header included
  Nanos timeout_ns = 100'000'000;          // a datagram not complete this long after its first fragment
  std::size_t max_fragments = 64;          // per datagram (65535 B / 1480 B = 45 at a 1500 MTU)
  std::size_t remember_completed = 256;    // completed datagrams whose late copies are told duplicates
};

enum class ReassemblyDrop : std::uint8_t {
  kTimeout = 0,  // a fragment never came (counted once per datagram)
  kOverlap,      // fragments overlap without being exact duplicates (RFC 5722's rule for IPv6)
  kTooMany,      // a new datagram while max_in_flight are open: the oldest is given up
  kOversize,     // the datagram would exceed max_datagram_bytes, or too many fragments
  kMalformed,    // bad IPv4 header, a fragment length not a multiple of 8, inconsistent last fragment
  kCount,
};
const char* to_string(ReassemblyDrop d) noexcept;

struct ReassemblyCounters {
  std::uint64_t fragments = 0;    // fragments pushed
  std::uint64_t duplicates = 0;   // exact duplicate fragments ignored
  std::uint64_t reassembled = 0;  // datagrams completed
  std::array<std::uint64_t, static_cast<std::size_t>(ReassemblyDrop::kCount)> dropped{};
  [[nodiscard]] std::uint64_t dropped_total() const noexcept;
};

enum class ReassemblyStatus : std::uint8_t {
  kNotFragment = 0,  // a whole datagram: use the input as it is
  kIncomplete,       // kept; more fragments needed
  kComplete,         // `datagram` holds the whole IPv4 datagram
  kDropped,          // this fragment (and its datagram when there was one) was given up, counted
};

struct ReassemblyResult {
  ReassemblyStatus status = ReassemblyStatus::kDropped;
  // kComplete: the first fragment's IPv4 header (options dropped, no fragment bits, length and
  // checksum recomputed) + the payload;
  // valid until the next push()/expire().
  std::span<const std::byte> datagram;
  Nanos rx_ns = 0;  // kComplete: the receive time of the fragment that completed it (as the kernel)
};

// The fragment fields of an IPv4 header; false when `packet` is not a sane IPv4 header.
struct Ipv4Header {
  std::uint32_t src = 0;  // host byte order
  std::uint32_t dst = 0;
  std::uint16_t id = 0;
  std::uint8_t proto = 0;
  std::uint16_t header_bytes = 0;
  std::uint16_t total_bytes = 0;
  std::uint32_t offset_bytes = 0;  // fragment offset
  bool more_fragments = false;
  [[nodiscard]] bool is_fragment() const noexcept { return more_fragments || offset_bytes != 0; }
};
bool parse_ipv4_header(std::span<const std::byte> packet, Ipv4Header& out) noexcept;

class Ipv4Reassembler {
 public:
  explicit Ipv4Reassembler(const Ipv4ReassemblerConfig& config = {});  // throws std::invalid_argument

  // One IPv4 packet as captured (from its IPv4 header; trailing link padding allowed), received at
  // `rx_ns` (the stamp a completed datagram gets) and `age_ns` (the clock the timeout runs on:
  // monotonic; the two-argument form uses rx_ns for both).
  ReassemblyResult push(std::span<const std::byte> packet, Nanos rx_ns, Nanos age_ns) noexcept;
  ReassemblyResult push(std::span<const std::byte> packet, Nanos rx_ns) noexcept { return push(packet, rx_ns, rx_ns); }
  // Gives up datagrams whose first fragment came (age clock) before now - timeout; returns how many.
  std::size_t expire(Nanos now) noexcept;

  [[nodiscard]] const ReassemblyCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] std::size_t in_flight() const noexcept;

 private:
  struct Range {
    std::uint32_t begin = 0;
    std::uint32_t end = 0;  // exclusive
  };
  enum class State : std::uint8_t { kFree, kOpen, kDead };  // dead: given up, swallows late fragments
  struct Entry {
    State state = State::kFree;
    std::uint32_t src = 0, dst = 0;
    std::uint16_t id = 0;
    std::uint8_t proto = 0;
    Nanos first_rx_ns = 0;            // age clock
    std::uint32_t total_payload = 0;  // known once the last fragment (MF=0) came; 0 = unknown
    std::vector<Range> ranges;        // payload received, unsorted, disjoint
    std::vector<std::byte> buffer;    // 20-byte header + payload
  };

  struct Completed {  // a datagram completed recently: its late fragment copies are duplicates
    std::uint32_t src = 0, dst = 0;
    std::uint16_t id = 0;
    std::uint8_t proto = 0;
    std::uint32_t total_payload = 0;
    Nanos at_ns = -1;  // age clock; -1: none
  };

  Entry* find(const Ipv4Header& h) noexcept;
  [[nodiscard]] bool completed_recently(const Ipv4Header& h, std::uint32_t end, Nanos age_ns) const noexcept;
  Entry* open(const Ipv4Header& h, Nanos rx_ns) noexcept;
  void drop(Entry& e, ReassemblyDrop why) noexcept;
  [[nodiscard]] bool complete(const Entry& e) const noexcept;

  Ipv4ReassemblerConfig config_;
  std::vector<Entry> entries_;
  std::vector<Completed> completed_;  // a ring, remember_completed long
  std::size_t completed_next_ = 0;
  ReassemblyCounters counters_;
};

}  // namespace sensor_rig::lidar
