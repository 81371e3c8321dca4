#pragma once
// IPv4 UDP sockets for packet sources and mock senders: an endpoint type and a small builder that
// applies socket options in order and returns the descriptor as a UniqueFd. Building throws
// (configuration); nothing here is on a hot path.
#include <netinet/in.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::lidar {

struct Endpoint {
  std::string host = "0.0.0.0";  // IPv4 literal or a name resolved with getaddrinfo
  std::uint16_t port = 0;        // 0 = ephemeral when binding
};

// "HOST:PORT" -> Endpoint; throws std::invalid_argument naming the text on a bad form or port.
Endpoint parse_endpoint(std::string_view text);

// Resolves to an IPv4 address; throws std::invalid_argument when the host is unknown.
sockaddr_in resolve(const Endpoint& ep);

class UdpSocketBuilder {
 public:
  UdpSocketBuilder& reuse_address(bool on = true);
  // Requested receive buffer in bytes; SO_RCVBUFFORCE is tried first (works as root, ignores
  // rmem_max), then SO_RCVBUF. The kernel doubles the value; read the result with
  // effective_receive_buffer().
  UdpSocketBuilder& receive_buffer(int bytes);
  UdpSocketBuilder& send_buffer(int bytes);
  UdpSocketBuilder& kernel_timestamps(bool on = true);  // SO_TIMESTAMPNS: CLOCK_REALTIME ns
  UdpSocketBuilder& drop_counter(bool on = true);       // SO_RXQ_OVFL: cumulative kernel drops
  UdpSocketBuilder& destination_address(bool on = true);  // IP_PKTINFO: each datagram's destination
  UdpSocketBuilder& nonblocking(bool on = true);
  UdpSocketBuilder& bind_to(Endpoint ep);

  // Creates the socket; throws std::system_error naming the failing option or address.
  [[nodiscard]] UniqueFd build() const;

 private:
  bool reuse_ = false;
  int rcvbuf_ = 0;
  int sndbuf_ = 0;
  bool timestamps_ = false;
  bool drops_ = false;
  bool pktinfo_ = false;
  bool nonblocking_ = false;
  std::optional<Endpoint> bind_;
};

// Receive buffer the kernel actually granted (getsockopt SO_RCVBUF), -1 on error.
int effective_receive_buffer(int fd) noexcept;
// Local port of a bound socket, 0 on error.
std::uint16_t local_port(int fd) noexcept;
// Local IPv4 address of a bound socket (host byte order; 0 for a wildcard bind or on error).
std::uint32_t local_address(int fd) noexcept;

}  // namespace sensor_rig::lidar
