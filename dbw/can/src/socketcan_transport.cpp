// SocketCAN raw socket: CAN 2.0 and FD frames, all error classes, kernel receive timestamps.
// Bus-off: reported by the controller as an error frame (CAN_ERR_BUSOFF) or ENETDOWN on send; while
// bus-off every send is refused (IoStatus::kBusOff) so nothing queues up to go out after recovery,
// and the send buffer is kept minimal so the kernel holds at most a few frames. Recovery is the
// CAN_ERR_RESTARTED error frame (driver restart-ms) or the controller reporting error-active again.
#include "socketcan_transport.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstring>

#include "socket_io.hpp"

namespace sensor_rig::dbw::can {

bool SocketCanTransport::available(int* err) noexcept {
  UniqueFd fd(::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW));
  if (err != nullptr) *err = fd ? 0 : errno;
  return static_cast<bool>(fd);
}

SocketCanTransport::SocketCanTransport(const std::string& iface) : iface_(iface) {
  fd_ = UniqueFd(::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW));
  if (!fd_) {
    const int e = errno;
    throw TransportError(std::string("socketcan:") + iface + ": socket(AF_CAN) failed: " + std::strerror(e) +
                         (e == EAFNOSUPPORT ? " (this kernel has no CAN support; use unix: or fd: transports)" : ""));
  }
  ifreq ifr{};
  if (iface.empty() || iface.size() >= sizeof ifr.ifr_name) throw TransportError("socketcan: bad interface name");
  std::memcpy(ifr.ifr_name, iface.data(), iface.size());
  if (::ioctl(fd_.get(), SIOCGIFINDEX, &ifr) != 0) {
    throw TransportError("socketcan:" + iface + ": no such interface: " + std::strerror(errno));
  }
  const int ifindex = ifr.ifr_ifindex;
  const std::string owner = "socketcan:" + iface;
  fd_capable_ = ::ioctl(fd_.get(), SIOCGIFMTU, &ifr) == 0 && ifr.ifr_mtu == static_cast<int>(CANFD_MTU);
  // An FD interface whose socket cannot take FD frames (an older kernel) still carries CAN 2.0.
  if (fd_capable_) {
    fd_capable_ = detail::optional_option(fd_.get(), SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1, "CAN_RAW_FD_FRAMES", owner,
                                          "CAN 2.0 frames only", stats_);
  }
  // Bus-off and the controller's state come from error frames: without them there is no bus state.
  detail::require_option(fd_.get(), SOL_CAN_RAW, CAN_RAW_ERR_FILTER, static_cast<int>(CAN_ERR_MASK),
                         "CAN_RAW_ERR_FILTER", owner);
  // The kernel rounds 0 up to its minimum: a few frames at most wait to go out after a bus-off.
  detail::require_option(fd_.get(), SOL_SOCKET, SO_SNDBUF, 0, "SO_SNDBUF", owner);
  detail::enable_timestamps(fd_.get(), owner, stats_);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  if (::bind(fd_.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    throw TransportError("socketcan:" + iface + ": bind: " + std::strerror(errno));
  }
}

IoStatus SocketCanTransport::send(const Frame& f) noexcept {
  if (state_ == BusState::kBusOff) {
    ++stats_.send_refused;
    return IoStatus::kBusOff;
  }
  if (f.fd && !fd_capable_) {
    ++stats_.send_refused;
    return IoStatus::kInvalid;
  }
  const IoStatus s = detail::send_frame(fd_.get(), f, stats_);
  if (s == IoStatus::kBusOff && state_ != BusState::kBusOff) {
    state_ = BusState::kBusOff;
    ++stats_.bus_off_events;
  }
  return s;
}

IoStatus SocketCanTransport::receive(RxFrame& out, int timeout_ms) noexcept {
  const IoStatus w = detail::wait_readable(fd_.get(), timeout_ms);
  if (w != IoStatus::kOk) return w;
  const IoStatus r = detail::recv_frame(fd_.get(), out, stats_);
  if (r == IoStatus::kOk && out.frame.error) note_error_frame(out.frame);
  return r;
}

}  // namespace sensor_rig::dbw::can
