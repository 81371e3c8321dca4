#pragma once
// Live packet source on an AF_PACKET TPACKET_V3 ring: the kernel copies one sensor's IPv4 packets
// (classic BPF filter, packet_filter.hpp) into blocks of a ring shared with this process; a block
// comes to us when full or after the retire timeout, so one poll() wakes for many packets. The
// receive stamp is the kernel's (tpacket3_hdr tp_sec/tp_nsec, CLOCK_REALTIME); fragments are
// reassembled here (ipv4_reassembler.hpp; their timeout on CLOCK_MONOTONIC); the ring's drops
// come from PACKET_STATISTICS.
// Same receive() contract as UdpSource, so the LIDAR driver uses either. One socket, one ring and
// one filter per sensor, for both of its ports: sensors on one interface do not share a ring (a slow
// consumer or a flooding sensor only fills its own ring, and each ring's drops are that sensor's
// drops); one sensor's data and IMU/position packets come through its ring in arrival order.
// Construction throws; receive() never throws and never allocates.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/lidar/ipv4_reassembler.hpp"
#include "sensor_rig/lidar/udp_source.hpp"

namespace sensor_rig::lidar {

struct RingSourceConfig {
  std::string interface;           // e.g. "eth1"; must exist when the source is built
  std::uint16_t port = 2368;       // the sensor's destination UDP port
  // Its second port (Ouster IMU, Velodyne position packets), 0 = none: the same filter and ring
  // take both; a slot's dst_port says which port a datagram came to.
  std::uint16_t second_port = 0;
  std::uint32_t sensor_host = 0;   // the sensor's IPv4 address (host byte order); 0 = any sender
  // Many small blocks: a block is handed over when full or after retire_timeout_ms, so at low rates
  // each block holds only that long's packets and block_count x retire_timeout_ms (here 512 ms) is
  // how long the reader may stall before the ring freezes and drops (16 x 1 MiB blocks dropped on
  // a loaded host: 64 ms of stall at 4 ms). 128 KiB: a 64 kB datagram fits.
  std::size_t block_bytes = 128 << 10;  // multiple of the page size, >= 128 KiB
  std::size_t block_count = 128;        // 16 MiB of ring per sensor
  // A block not yet full is handed over after this long: the added latency at low packet rates.
  int retire_timeout_ms = 4;
  Ipv4ReassemblerConfig reassembly{};
};

struct RingSourceStats {
  std::uint64_t packets = 0;      // datagrams delivered
  std::uint64_t bytes = 0;        // UDP payload bytes delivered
  std::uint64_t truncated = 0;    // larger than the caller's slot, or cut short in the ring
  std::uint64_t filtered = 0;     // passed the kernel filter, not the sensor's (port after reassembly, bad UDP)
  std::uint64_t second_port_packets = 0;  // of `packets`: to the second port
  std::uint64_t blocks = 0;       // ring blocks consumed
  std::uint64_t timeouts = 0;
  std::uint64_t errors = 0;
  std::uint64_t missing_timestamps = 0;  // frames with tp_sec == 0 (host clock used)
  // PACKET_STATISTICS (tpacket_stats_v3), accumulated (the kernel resets them on each read).
  std::uint64_t ring_packets = 0;   // frames the filter accepted, dropped ones included
  std::uint64_t ring_drops = 0;     // frames lost because the ring was full
  std::uint64_t ring_freeze_q = 0;  // times the ring was found frozen (all blocks with us)
  ReassemblyCounters reassembly;
};

class RingSource {
 public:
  // Throws std::invalid_argument (config), std::runtime_error (unknown interface),
  // std::system_error (socket, option, mmap or bind refused; AF_PACKET needs CAP_NET_RAW).
  explicit RingSource(const RingSourceConfig& config);
  RingSource(RingSource&&) noexcept;
  RingSource& operator=(RingSource&&) noexcept;
  RingSource(const RingSource&) = delete;
  RingSource& operator=(const RingSource&) = delete;
  ~RingSource();

  // Waits up to timeout_ms (0 = poll, -1 = forever) for datagrams and fills up to out.size() slots.
  RecvResult receive(std::span<PacketSlot> out, int timeout_ms) noexcept;
  // Reads PACKET_STATISTICS into stats() now (receive() does it at most every 100 ms).
  void refresh_kernel_stats() noexcept;

  [[nodiscard]] std::uint16_t port() const noexcept { return config_.port; }
  [[nodiscard]] const std::string& interface() const noexcept { return config_.interface; }
  [[nodiscard]] const RingSourceStats& stats() const noexcept { return stats_; }
  [[nodiscard]] int fd() const noexcept { return fd_.get(); }

 private:
  std::size_t drain(std::span<PacketSlot> out) noexcept;
  bool deliver(const std::byte* frame, PacketSlot& slot) noexcept;
  void release_block() noexcept;

  RingSourceConfig config_;
  UniqueFd fd_;
  std::byte* ring_ = nullptr;  // mmap'ed block_bytes * block_count
  std::size_t ring_bytes_ = 0;
  std::size_t block_ = 0;               // the block we read next / are reading
  std::uint32_t packets_left_ = 0;      // in the block being read
  const std::byte* next_ = nullptr;     // next frame of the block being read; null = no block open
  Ipv4Reassembler reassembler_;
  ClockPair drain_clocks_;   // both clocks at the drain: each datagram's stamp on CLOCK_MONOTONIC
  Nanos drain_mono_ns_ = 0;  // CLOCK_MONOTONIC of the drain: the reassembly timeout's clock
  Nanos last_stats_ns_ = 0;
  RingSourceStats stats_;
};

}  // namespace sensor_rig::lidar
