#include "socket_io.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace sensor_rig::dbw::can::detail {

void enable_timestamps(int fd) noexcept {
  const int on = 1;
  (void)::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
}

IoStatus send_frame(int fd, const Frame& f, TransportStats& stats) noexcept {
  std::array<std::uint8_t, kFdWireSize> buf{};
  const std::size_t n = to_wire(f, buf);
  if (n == 0) {
    ++stats.send_refused;
    return IoStatus::invalid;
  }
  const ssize_t r = ::send(fd, buf.data(), n, MSG_DONTWAIT | MSG_NOSIGNAL);
  if (r == static_cast<ssize_t>(n)) {
    ++stats.sent;
    return IoStatus::ok;
  }
  stats.last_errno = r < 0 ? errno : EMSGSIZE;
  ++stats.send_refused;
  if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) return IoStatus::would_block;
  if (r < 0 && (errno == EPIPE || errno == ECONNRESET || errno == ENOTCONN)) return IoStatus::closed;
  if (r < 0 && errno == ENETDOWN) return IoStatus::bus_off;
  return IoStatus::error;
}

IoStatus recv_frame(int fd, RxFrame& out, TransportStats& stats) noexcept {
  std::array<std::uint8_t, kFdWireSize + 8> buf{};
  alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(timespec)) + 64> ctrl{};
  iovec iov{buf.data(), buf.size()};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = ctrl.data();
  msg.msg_controllen = ctrl.size();
  const ssize_t n = ::recvmsg(fd, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) return IoStatus::timeout;
    stats.last_errno = errno;
    if (errno == ECONNRESET) return IoStatus::closed;
    return IoStatus::error;
  }
  if (n == 0) return IoStatus::closed;
  out.stamp = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      out.stamp = static_cast<Nanos>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
    }
  }
  if (out.stamp == 0) out.stamp = vehicle_now_ns();
  if ((msg.msg_flags & MSG_TRUNC) != 0 ||
      from_wire(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)), out.frame) != WireStatus::ok) {
    ++stats.rx_dropped;
    return IoStatus::invalid;
  }
  ++stats.received;
  return IoStatus::ok;
}

IoStatus wait_readable(int fd, int timeout_ms) noexcept {
  pollfd p{fd, POLLIN, 0};
  while (true) {
    const int r = ::poll(&p, 1, timeout_ms);
    if (r > 0) return IoStatus::ok;
    if (r == 0) return IoStatus::timeout;
    if (errno != EINTR) return IoStatus::error;
  }
}

}  // namespace sensor_rig::dbw::can::detail
