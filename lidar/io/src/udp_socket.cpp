#include "sensor_rig/lidar/udp_socket.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <sys/socket.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>
#include <string>
#include <system_error>

#include "sensor_rig/common/socket_options.hpp"

namespace sensor_rig::lidar {
namespace {

[[noreturn]] void throw_errno(const std::string& what) {
  throw std::system_error(errno, std::generic_category(), what);
}

}  // namespace

Endpoint parse_endpoint(std::string_view text) {
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size()) {
    throw std::invalid_argument("expected HOST:PORT, got '" + std::string(text) + "'");
  }
  const std::string_view port_text = text.substr(colon + 1);
  unsigned port = 0;
  const auto [ptr, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc{} || ptr != port_text.data() + port_text.size() || port > 65535) {
    throw std::invalid_argument("bad port '" + std::string(port_text) + "' in '" + std::string(text) + "'");
  }
  return Endpoint{std::string(text.substr(0, colon)), static_cast<std::uint16_t>(port)};
}

sockaddr_in resolve(const Endpoint& ep) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(ep.port);
  if (::inet_pton(AF_INET, ep.host.c_str(), &addr.sin_addr) == 1) return addr;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  const int rc = ::getaddrinfo(ep.host.c_str(), nullptr, &hints, &res);
  if (rc != 0 || res == nullptr) {
    throw std::invalid_argument("cannot resolve host '" + ep.host + "': " + ::gai_strerror(rc));
  }
  std::memcpy(&addr.sin_addr, &reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr, sizeof addr.sin_addr);
  ::freeaddrinfo(res);
  return addr;
}

UdpSocketBuilder& UdpSocketBuilder::reuse_address(bool on) {
  reuse_ = on;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::receive_buffer(int bytes) {
  if (bytes < 0) throw std::invalid_argument("receive buffer must be >= 0 bytes");
  rcvbuf_ = bytes;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::send_buffer(int bytes) {
  if (bytes < 0) throw std::invalid_argument("send buffer must be >= 0 bytes");
  sndbuf_ = bytes;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::kernel_timestamps(bool on) {
  timestamps_ = on;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::drop_counter(bool on) {
  drops_ = on;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::destination_address(bool on) {
  pktinfo_ = on;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::nonblocking(bool on) {
  nonblocking_ = on;
  return *this;
}
UdpSocketBuilder& UdpSocketBuilder::bind_to(Endpoint ep) {
  bind_ = std::move(ep);
  return *this;
}

UniqueFd UdpSocketBuilder::build() const {
  const int type = SOCK_DGRAM | SOCK_CLOEXEC | (nonblocking_ ? SOCK_NONBLOCK : 0);
  UniqueFd fd(::socket(AF_INET, type, 0));
  if (!fd) throw_errno("socket(AF_INET, SOCK_DGRAM)");
  if (reuse_) set_socket_option(fd.get(), SOL_SOCKET, SO_REUSEADDR, 1, "SO_REUSEADDR");
  if (rcvbuf_ > 0) {
    // The kernel doubles the request; ask for half so the granted size matches the request.
    const int half = rcvbuf_ / 2 > 0 ? rcvbuf_ / 2 : 1;
    if (!try_socket_option(fd.get(), SOL_SOCKET, SO_RCVBUFFORCE, half)) {
      set_socket_option(fd.get(), SOL_SOCKET, SO_RCVBUF, half, "SO_RCVBUF");  // unprivileged: capped by rmem_max
    }
  }
  if (sndbuf_ > 0) {
    const int half = sndbuf_ / 2 > 0 ? sndbuf_ / 2 : 1;
    if (!try_socket_option(fd.get(), SOL_SOCKET, SO_SNDBUFFORCE, half)) {
      set_socket_option(fd.get(), SOL_SOCKET, SO_SNDBUF, half, "SO_SNDBUF");
    }
  }
  if (timestamps_) set_socket_option(fd.get(), SOL_SOCKET, SO_TIMESTAMPNS, 1, "SO_TIMESTAMPNS");
  if (drops_) set_socket_option(fd.get(), SOL_SOCKET, SO_RXQ_OVFL, 1, "SO_RXQ_OVFL");
  if (pktinfo_) set_socket_option(fd.get(), IPPROTO_IP, IP_PKTINFO, 1, "IP_PKTINFO");
  if (bind_) {
    const sockaddr_in addr = resolve(*bind_);
    if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
      throw_errno("bind " + bind_->host + ":" + std::to_string(bind_->port));
    }
  }
  return fd;
}

int effective_receive_buffer(int fd) noexcept {
  int value = 0;
  socklen_t len = sizeof value;
  if (::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &value, &len) != 0) return -1;
  return value;
}

std::uint16_t local_port(int fd) noexcept {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return 0;
  return ntohs(addr.sin_port);
}

std::uint32_t local_address(int fd) noexcept {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return 0;
  return ntohl(addr.sin_addr.s_addr);
}

}  // namespace sensor_rig::lidar
