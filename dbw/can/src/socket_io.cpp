#include "socket_io.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>
#include <system_error>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/socket_options.hpp"

namespace sensor_rig::dbw::can::detail {

void require_option(int fd, int level, int opt, int value, const char* name, std::string_view owner) {
  try {
    set_socket_option(fd, level, opt, value, name);
  } catch (const std::system_error& e) {
    throw TransportError(std::string(owner) + ": " + e.what());
  }
}

bool optional_option(int fd, int level, int opt, int value, const char* name, std::string_view owner,
                     std::string_view without, TransportStats& stats) noexcept {
  if (try_socket_option(fd, level, opt, value)) return true;
  const int e = errno;
  stats.last_errno = e;
  ++stats.options_refused;
  try {
    log::warn("can", std::string(owner) + ": setsockopt " + name + ": " + std::strerror(e) + " (" +
                         std::string(without) + ")");
  } catch (...) {
    // No memory for the message: the count stands.
  }
  return false;
}

bool enable_timestamps(int fd, std::string_view owner, TransportStats& stats) noexcept {
  return optional_option(fd, SOL_SOCKET, SO_TIMESTAMPNS, 1, "SO_TIMESTAMPNS", owner,
                         "frames are stamped on receipt in user space", stats);
}

IoStatus send_frame(int fd, const Frame& f, TransportStats& stats) noexcept {
  std::array<std::uint8_t, kFdWireSize> buf{};
  const std::size_t n = to_wire(f, buf);
  if (n == 0) {
    ++stats.send_refused;
    return IoStatus::kInvalid;
  }
  const ssize_t r = ::send(fd, buf.data(), n, MSG_DONTWAIT | MSG_NOSIGNAL);
  if (r == static_cast<ssize_t>(n)) {
    ++stats.sent;
    return IoStatus::kOk;
  }
  stats.last_errno = r < 0 ? errno : EMSGSIZE;
  ++stats.send_refused;
  if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) return IoStatus::kWouldBlock;
  if (r < 0 && (errno == EPIPE || errno == ECONNRESET || errno == ENOTCONN)) return IoStatus::kClosed;
  if (r < 0 && errno == ENETDOWN) return IoStatus::kBusOff;
  return IoStatus::kError;
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
    if (errno == EAGAIN || errno == EWOULDBLOCK) return IoStatus::kTimeout;
    stats.last_errno = errno;
    if (errno == ECONNRESET) return IoStatus::kClosed;
    return IoStatus::kError;
  }
  if (n == 0) return IoStatus::kClosed;
  out.stamp = read_receive_control(msg).kernel_rx_ns;
  if (out.stamp == 0) out.stamp = vehicle_now_ns();
  if ((msg.msg_flags & MSG_TRUNC) != 0 ||
      from_wire(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)), out.frame) != WireStatus::kOk) {
    ++stats.rx_dropped;
    return IoStatus::kInvalid;
  }
  ++stats.received;
  return IoStatus::kOk;
}

IoStatus wait_readable(int fd, int timeout_ms) noexcept {
  pollfd p{fd, POLLIN, 0};
  while (true) {
    const int r = ::poll(&p, 1, timeout_ms);
    if (r > 0) return IoStatus::kOk;
    if (r == 0) return IoStatus::kTimeout;
    if (errno != EINTR) return IoStatus::kError;
  }
}

}  // namespace sensor_rig::dbw::can::detail
