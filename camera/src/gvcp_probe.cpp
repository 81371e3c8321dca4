#include "gvcp_probe.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>

#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::detail {
namespace {

constexpr std::uint16_t kGvcpPort = 3956;
constexpr std::uint8_t kCommandKey = 0x42;    // GVCP command packet
constexpr std::uint8_t kAckRequired = 0x01;
constexpr std::uint16_t kReadRegCmd = 0x0080;
constexpr std::uint16_t kReadRegAck = 0x0081;
constexpr std::uint32_t kVersionRegister = 0x0000;  // bootstrap: GigE Vision version

void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
std::uint16_t get16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

bool is_ipv4_address(const std::string& device) noexcept {
  in_addr ip{};
  return ::inet_pton(AF_INET, device.c_str(), &ip) == 1;
}

std::string probe_gvcp(const std::string& address, const GvcpProbe& how) {
  const std::string what = "aravis " + address + ": ";
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(kGvcpPort);
  if (::inet_pton(AF_INET, address.c_str(), &to.sin_addr) != 1) throw CameraError(what + "not an IPv4 address");
  Fd s;
  s.fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (s.fd < 0) throw CameraError(what + "GVCP probe socket: " + std::strerror(errno));
  if (::connect(s.fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0)
    throw CameraError(what + "no route (" + std::strerror(errno) + ")");
  sockaddr_in local{};
  socklen_t len = sizeof local;
  if (::getsockname(s.fd, reinterpret_cast<sockaddr*>(&local), &len) != 0)
    throw CameraError(what + "GVCP probe socket: " + std::strerror(errno));
  std::array<char, INET_ADDRSTRLEN> iface{};
  ::inet_ntop(AF_INET, &local.sin_addr, iface.data(), iface.size());
  std::string refused;
  for (int k = 0; k < how.tries; ++k) {
    const auto id = static_cast<std::uint16_t>(0x7000 + k + 1);  // never 0
    std::array<std::uint8_t, 12> cmd{kCommandKey, kAckRequired};
    put16(&cmd[2], kReadRegCmd);
    put16(&cmd[4], 4);
    put16(&cmd[6], id);
    cmd[8] = static_cast<std::uint8_t>(kVersionRegister >> 24);
    cmd[9] = static_cast<std::uint8_t>(kVersionRegister >> 16);
    cmd[10] = static_cast<std::uint8_t>(kVersionRegister >> 8);
    cmd[11] = static_cast<std::uint8_t>(kVersionRegister);
    if (::send(s.fd, cmd.data(), cmd.size(), 0) < 0 && errno != ECONNREFUSED) throw CameraError(what + "GVCP send: " + std::strerror(errno));
    const Nanos until = monotonic_now_ns() + static_cast<Nanos>(how.timeout_ms) * 1'000'000;
    for (Nanos now = monotonic_now_ns(); now < until; now = monotonic_now_ns()) {
      pollfd p{s.fd, POLLIN, 0};
      const int r = ::poll(&p, 1, static_cast<int>((until - now + 999'999) / 1'000'000));
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) break;
      std::array<std::uint8_t, 64> ack{};
      const ssize_t n = ::recv(s.fd, ack.data(), ack.size(), 0);
      if (n < 0) {
        // Nothing listens there (ICMP port unreachable: a host without the camera's service). A
        // real camera that lost power says nothing at all; either way: no answer, try again.
        if (errno == ECONNREFUSED) refused = " (port unreachable)";
        if (errno == EINTR || errno == ECONNREFUSED) continue;
        break;
      }
      // ACK: status, READREG_ACK, length, the request's id: any status is a camera answering.
      if (n >= 8 && get16(&ack[2]) == kReadRegAck && get16(&ack[6]) == id) return iface.data();
    }
  }
  throw CameraError(what + "does not answer GVCP (" + std::to_string(how.tries) + " x " + std::to_string(how.timeout_ms) +
                    " ms)" + refused);
}

bool answers_gvcp(const std::string& address, const GvcpProbe& how) noexcept {
  try {
    (void)probe_gvcp(address, how);
    return true;
  } catch (...) {
    return false;
  }
}

}  // namespace sensor_rig::camera::detail
