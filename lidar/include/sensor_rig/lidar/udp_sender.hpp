#pragma once
// UDP sender for mock sensors: one unconnected socket, datagrams addressed per packet, so a
// missing receiver (ICMP port unreachable) never turns into send errors. send_batch() uses
// sendmmsg. Construction throws; sends return counts and errno, never throw, never allocate.
#include <netinet/in.h>
#include <sys/socket.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/lidar/udp_socket.hpp"

namespace sensor_rig::lidar {

struct OutDatagram {
  std::span<const std::byte> data;
  std::size_t destination = 0;  // index into the sender's destinations
  // Source IPv4 (host order) for this datagram, a local address (IP_PKTINFO); 0 = the socket's.
  // The mock's second sensor sends from another address, as a real one would (issue 26 item 6).
  std::uint32_t source_addr = 0;
};

struct SendResult {
  std::size_t sent = 0;  // datagrams handed to the kernel
  int error = 0;         // errno of the first failure (0 = none)
};

struct UdpSenderStats {
  std::uint64_t packets = 0;
  std::uint64_t bytes = 0;
  std::uint64_t errors = 0;   // datagrams the kernel refused (ENOBUFS, ...)
  std::uint64_t batches = 0;  // sendmmsg calls
};

class UdpSender {
 public:
  // destinations[i] is addressed by OutDatagram::destination == i.
  explicit UdpSender(std::span<const Endpoint> destinations, int send_buffer_bytes = 4 << 20,
                     std::size_t max_batch = 64);

  SendResult send(std::span<const std::byte> data, std::size_t destination = 0) noexcept;
  // Sends all datagrams in order (several sendmmsg calls when more than max_batch); a datagram
  // that fails is counted and skipped.
  SendResult send_batch(std::span<const OutDatagram> batch) noexcept;

  [[nodiscard]] const UdpSenderStats& stats() const noexcept { return stats_; }
  [[nodiscard]] std::size_t destinations() const noexcept { return dests_.size(); }
  // Destination i's IPv4 address, host order.
  [[nodiscard]] std::uint32_t destination_addr(std::size_t i) const noexcept;

 private:
  UniqueFd fd_;
  std::vector<sockaddr_in> dests_;
  std::vector<mmsghdr> msgs_;
  std::vector<iovec> iovs_;
  std::vector<std::array<char, CMSG_SPACE(sizeof(in_pktinfo))>> ctrl_;  // IP_PKTINFO per datagram
  UdpSenderStats stats_;
};

}  // namespace sensor_rig::lidar
