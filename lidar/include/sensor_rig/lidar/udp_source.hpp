#pragma once
// Live UDP packet source: one bound socket, batched reception with recvmmsg, the kernel's receive
// timestamp (SO_TIMESTAMPNS, CLOCK_REALTIME) per packet and its drop counter (SO_RXQ_OVFL).
// I/O only: no decoding, no DDS. Construction throws; receive() never throws and never allocates.
#include <netinet/in.h>
#include <sys/socket.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/udp_socket.hpp"

namespace sensor_rig::lidar {

struct UdpSourceConfig {
  Endpoint bind{"0.0.0.0", 2368};   // port 0 = ephemeral, see UdpSource::port()
  int receive_buffer_bytes = 8 << 20;  // 0 = kernel default
  std::size_t max_batch = 64;          // packets per recvmmsg call
  bool reuse_address = true;
};

// The largest IPv4 header (with options) and the UDP header after it.
inline constexpr std::size_t kMaxIpUdpHeaderSize = 60 + 8;

// One received datagram. `buffer` is storage owned by the caller (see SlotArena); the source
// fills size, rx_ns and both ends' addresses.
struct PacketSlot {
  std::span<std::byte> buffer;
  std::size_t size = 0;       // bytes stored (a truncated datagram fills the whole buffer)
  Nanos rx_ns = 0;            // kernel receive time, CLOCK_REALTIME ns
  Nanos rx_mono_ns = 0;       // the same on CLOCK_MONOTONIC (0: unknown): monotonic_receive_ns
  bool truncated = false;     // the datagram was larger than the buffer
  std::uint32_t src_addr = 0; // IPv4, host byte order
  std::uint16_t src_port = 0;
  std::uint32_t dst_addr = 0; // the datagram's destination (IP_PKTINFO / the captured header)
  std::uint16_t dst_port = 0;
  // The IPv4 + UDP headers as captured (packet ring only: a UDP socket's kernel strips them);
  // a reassembled datagram's are its first fragment's, fragment bits cleared, length and checksum
  // recomputed. A recording keeps them, so it shows what was on the wire.
  std::array<std::byte, kMaxIpUdpHeaderSize> ip_udp_header{};
  std::uint8_t ip_udp_header_size = 0;  // 0 = not captured

  [[nodiscard]] std::span<const std::byte> bytes() const noexcept { return buffer.first(size); }
  [[nodiscard]] std::span<const std::byte> captured_headers() const noexcept {
    return std::span<const std::byte>(ip_udp_header).first(ip_udp_header_size);
  }
};

// Fixed storage for `count` slots of `slot_bytes` each, allocated once.
class SlotArena {
 public:
  explicit SlotArena(std::size_t count, std::size_t slot_bytes = 2048);
  SlotArena(const SlotArena&) = delete;  // the slots point into this arena's storage
  SlotArena& operator=(const SlotArena&) = delete;
  SlotArena(SlotArena&&) noexcept = default;
  SlotArena& operator=(SlotArena&&) noexcept = default;
  [[nodiscard]] std::span<PacketSlot> slots() noexcept { return slots_; }

 private:
  std::vector<std::byte> storage_;
  std::vector<PacketSlot> slots_;
};

enum class RecvStatus : std::uint8_t {
  kOk = 0,       // count >= 1 packets received
  kTimeout,      // nothing arrived within the timeout
  kInterrupted,  // a signal interrupted the wait (check the shutdown flag and call again)
  kError,        // a socket error; `error` holds errno
};
const char* to_string(RecvStatus s) noexcept;

struct RecvResult {
  std::size_t count = 0;
  RecvStatus status = RecvStatus::kOk;
  int error = 0;
};

struct UdpSourceStats {
  std::uint64_t packets = 0;
  std::uint64_t bytes = 0;
  std::uint64_t truncated = 0;
  std::uint64_t kernel_drops = 0;  // cumulative, from SO_RXQ_OVFL (latest value seen)
  std::uint64_t batches = 0;       // recvmmsg calls that returned packets
  std::uint64_t timeouts = 0;
  std::uint64_t errors = 0;
  std::uint64_t missing_timestamps = 0;  // packets without SCM_TIMESTAMPNS (host clock used)
};

class UdpSource {
 public:
  explicit UdpSource(const UdpSourceConfig& config);  // throws std::system_error / invalid_argument
  UdpSource(UdpSource&&) noexcept = default;
  UdpSource& operator=(UdpSource&&) noexcept = default;

  // Waits up to timeout_ms (0 = poll, -1 = forever) for packets, then reads up to
  // min(out.size(), max_batch) of them without blocking.
  RecvResult receive(std::span<PacketSlot> out, int timeout_ms) noexcept;

  [[nodiscard]] std::uint16_t port() const noexcept { return port_; }
  [[nodiscard]] int receive_buffer_bytes() const noexcept { return rcvbuf_; }  // as granted
  [[nodiscard]] const UdpSourceStats& stats() const noexcept { return stats_; }
  [[nodiscard]] int fd() const noexcept { return fd_.get(); }

 private:
  // SCM_TIMESTAMPNS (32), SO_RXQ_OVFL (24) and IP_PKTINFO (32) control messages.
  static constexpr std::size_t kControlBytes = 128;

  UniqueFd fd_;
  std::uint16_t port_ = 0;
  std::uint32_t local_addr_ = 0;  // the bound address; a wildcard bind relies on IP_PKTINFO
  int rcvbuf_ = 0;
  std::size_t max_batch_ = 0;
  UdpSourceStats stats_;
  std::vector<mmsghdr> msgs_;
  std::vector<iovec> iovs_;
  std::vector<sockaddr_in> addrs_;
  std::vector<std::byte> control_;
};

// The decoder's view of a received slot.
inline PacketView view(const PacketSlot& slot, std::uint16_t dst_port) noexcept {
  return PacketView{slot.bytes(), slot.rx_ns, dst_port, slot.rx_mono_ns};
}

}  // namespace sensor_rig::lidar
