// AF_UNIX SOCK_SEQPACKET transports: one connected end (socketpair, unix:PATH, fd:N) and the bus
// owner (unix-listen:PATH) which relays every frame between all connected peers.
#include "seqpacket_transport.hpp"

#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "socket_io.hpp"

namespace sensor_rig::dbw::can {
namespace {

sockaddr_un unix_address(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof a.sun_path) throw TransportError("unix socket path empty or too long: " + path);
  std::memcpy(a.sun_path, path.data(), path.size());
  return a;
}

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

Nanos deadline_after(int timeout_ms) {
  return timeout_ms < 0 ? -1 : monotonic_now_ns() + static_cast<Nanos>(timeout_ms) * 1'000'000LL;
}
int remaining_ms(Nanos deadline) {
  if (deadline < 0) return -1;
  const Nanos left = deadline - monotonic_now_ns();
  return left <= 0 ? 0 : static_cast<int>((left + 999'999) / 1'000'000);
}

}  // namespace

SeqpacketTransport::SeqpacketTransport(UniqueFd fd, std::string name, std::string reconnect_path)
    : fd_(std::move(fd)), name_(std::move(name)), reconnect_path_(std::move(reconnect_path)) {
  if (!fd_) throw TransportError("invalid descriptor for " + name_);
  detail::enable_timestamps(fd_.get(), name_, stats_);
}

IoStatus SeqpacketTransport::send(const Frame& f) noexcept {
  if (state_ == BusState::kBusOff) {
    ++stats_.send_refused;
    return IoStatus::kBusOff;
  }
  std::lock_guard lock(fd_mu_);
  const IoStatus r = detail::send_frame(fd_.get(), f, stats_);
  // The bus owner went away between our reads: the receiving thread notices and reconnects.
  return r == IoStatus::kClosed && !reconnect_path_.empty() ? IoStatus::kBusOff : r;
}

bool SeqpacketTransport::try_reconnect() noexcept {
  const Nanos now = monotonic_now_ns();
  if (now < next_attempt_ns_) return false;
  next_attempt_ns_ = now + 100'000'000;
  UniqueFd fd(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!fd) return false;
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::memcpy(a.sun_path, reconnect_path_.data(), std::min(reconnect_path_.size(), sizeof a.sun_path - 1));
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) return false;
  detail::enable_timestamps(fd.get(), name_, stats_);
  {
    std::lock_guard lock(fd_mu_);
    fd_ = std::move(fd);
  }
  disconnected_ = false;
  state_ = BusState::kActive;
  return true;
}

IoStatus SeqpacketTransport::receive(RxFrame& out, int timeout_ms) noexcept {
  const Nanos deadline = deadline_after(timeout_ms);
  while (true) {
    // Only a lost connection is retried: a bus-off the bus itself reported (an error frame) stays
    // until the bus says it restarted.
    if (disconnected_ && !try_reconnect()) {
      // Off the bus: nothing arrives; wait out the timeout in short steps so a reconnect is prompt.
      const int left = remaining_ms(deadline);
      if (left == 0) return IoStatus::kTimeout;
      timespec ts{0, static_cast<long>(std::min(left < 0 ? 10 : left, 10)) * 1'000'000L};
      ::nanosleep(&ts, nullptr);
      continue;
    }
    const IoStatus w = detail::wait_readable(fd_.get(), remaining_ms(deadline));
    if (w != IoStatus::kOk) return w;
    IoStatus r = detail::recv_frame(fd_.get(), out, stats_);
    if (r == IoStatus::kClosed && !reconnect_path_.empty()) {
      disconnected_ = true;
      state_ = BusState::kBusOff;  // the bridge sees it as a bus-off: disengaged, nothing sent
      ++stats_.bus_off_events;
      next_attempt_ns_ = 0;
      continue;
    }
    if (r == IoStatus::kTimeout || r == IoStatus::kInvalid) {
      if (remaining_ms(deadline) == 0) return IoStatus::kTimeout;
      continue;
    }
    if (r == IoStatus::kOk && out.frame.error) note_error_frame(out.frame);
    return r;
  }
}

std::unique_ptr<Transport> SeqpacketTransport::connect(const std::string& path) {
  UniqueFd fd(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!fd) throw TransportError(errno_text("socket(AF_UNIX, SOCK_SEQPACKET)"));
  const sockaddr_un a = unix_address(path);
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    throw TransportError(errno_text("connect " + path));
  }
  return std::make_unique<SeqpacketTransport>(std::move(fd), "unix:" + path, path);
}

// ---- bus owner -------------------------------------------------------------------------------

BusListener::BusListener(const std::string& path) : path_(path), name_("unix-listen:" + path) {
  listen_ = UniqueFd(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC | SOCK_NONBLOCK, 0));
  if (!listen_) throw TransportError(errno_text("socket(AF_UNIX, SOCK_SEQPACKET)"));
  const sockaddr_un a = unix_address(path);
  ::unlink(path.c_str());  // a stale socket file from an earlier run
  if (::bind(listen_.get(), reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    throw TransportError(errno_text("bind " + path));
  }
  if (::listen(listen_.get(), 8) != 0) throw TransportError(errno_text("listen " + path));
  epoll_ = UniqueFd(::epoll_create1(EPOLL_CLOEXEC));
  if (!epoll_) throw TransportError(errno_text("epoll_create1"));
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.fd = listen_.get();
  if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, listen_.get(), &ev) != 0) throw TransportError(errno_text("epoll_ctl"));
}

BusListener::~BusListener() { ::unlink(path_.c_str()); }

void BusListener::accept_peers() noexcept {
  while (true) {
    UniqueFd c(::accept4(listen_.get(), nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK));
    if (!c) return;
    detail::enable_timestamps(c.get(), name_, stats_);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = c.get();
    if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, c.get(), &ev) == 0) peers_.push_back(std::move(c));
  }
}

void BusListener::drop_peer(int fd) noexcept {
  for (auto it = peers_.begin(); it != peers_.end(); ++it) {
    if (it->get() == fd) {
      ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, fd, nullptr);
      peers_.erase(it);
      return;
    }
  }
}

void BusListener::relay(const Frame& f, int except_fd) noexcept {
  TransportStats scratch;
  for (std::size_t i = 0; i < peers_.size();) {
    const int fd = peers_[i].get();
    if (fd == except_fd) {
      ++i;
      continue;
    }
    if (detail::send_frame(fd, f, scratch) == IoStatus::kClosed) {
      drop_peer(fd);
      continue;
    }
    ++i;
  }
}

IoStatus BusListener::send(const Frame& f) noexcept {
  if (state_ == BusState::kBusOff) {
    ++stats_.send_refused;
    return IoStatus::kBusOff;
  }
  std::array<std::uint8_t, kFdWireSize> buf{};
  if (to_wire(f, buf) == 0) {
    ++stats_.send_refused;
    return IoStatus::kInvalid;
  }
  {
    std::lock_guard<std::mutex> lock(peers_mu_);
    accept_peers();
    relay(f, -1);
    last_heard_ = !peers_.empty();  // a peer that took it is still there (one that closed was dropped)
  }
  ++stats_.sent;
  return IoStatus::kOk;
}

IoStatus BusListener::receive(RxFrame& out, int timeout_ms) noexcept {
  const Nanos deadline = deadline_after(timeout_ms);
  while (true) {
    epoll_event ev{};
    const int n = ::epoll_wait(epoll_.get(), &ev, 1, remaining_ms(deadline));
    if (n < 0) {
      if (errno == EINTR) continue;
      stats_.last_errno = errno;
      return IoStatus::kError;
    }
    if (n == 0) return IoStatus::kTimeout;
    std::lock_guard<std::mutex> lock(peers_mu_);
    if (ev.data.fd == listen_.get()) {
      accept_peers();
      continue;
    }
    // The sending thread may have dropped this peer since epoll_wait returned.
    if (std::none_of(peers_.begin(), peers_.end(), [&](const UniqueFd& p) { return p.get() == ev.data.fd; })) continue;
    const IoStatus r = detail::recv_frame(ev.data.fd, out, stats_);
    if (r == IoStatus::kClosed || r == IoStatus::kError) {
      drop_peer(ev.data.fd);
      continue;
    }
    if (r != IoStatus::kOk) continue;
    relay(out.frame, ev.data.fd);  // everyone on the bus sees every frame
    return IoStatus::kOk;
  }
}

std::pair<std::unique_ptr<Transport>, std::unique_ptr<Transport>> make_socketpair() {
  int sv[2] = {-1, -1};
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) throw TransportError(errno_text("socketpair"));
  UniqueFd a(sv[0]);
  UniqueFd b(sv[1]);
  return {std::make_unique<SeqpacketTransport>(std::move(a), "socketpair:0"),
          std::make_unique<SeqpacketTransport>(std::move(b), "socketpair:1")};
}

}  // namespace sensor_rig::dbw::can
