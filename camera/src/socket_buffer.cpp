#include "socket_buffer.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>

namespace sensor_rig::camera::detail {

SocketBufferCheck check_socket_buffer(std::int64_t asked, std::size_t frame_payload_bytes) noexcept {
  SocketBufferCheck c;
  c.asked = asked;
  // The kernel charges each datagram its buffer's true size (~2.3 kB for a 1.5 kB packet) and
  // doubles the SO_RCVBUF request for it: one frame in flight needs about twice its payload.
  c.needed = 2 * static_cast<std::int64_t>(frame_payload_bytes);
  std::ifstream("/proc/sys/net/core/rmem_max") >> c.rmem_max;  // read, never written
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return c;
  const int want = static_cast<int>(std::clamp<std::int64_t>(asked, 0, 1 << 30));
  int got = 0;
  socklen_t len = sizeof got;
  if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &want, sizeof want) == 0 &&
      ::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &len) == 0)
    c.granted = got;
  ::close(fd);
  return c;
}

std::string socket_buffer_advice(const std::string& device, const SocketBufferCheck& c) {
  // What one frame needs, as a request (the kernel doubles the request it grants).
  const std::int64_t want = std::max(c.asked, (c.needed + 1) / 2);
  std::string out = "aravis " + device + ": stream socket buffer granted " + std::to_string(c.granted) + " bytes, a frame needs ~" +
                    std::to_string(c.needed) + ": frames will lose packets. ";
  if (c.asked < want) out += "Set socket_buffer_bytes to at least " + std::to_string(want) + " (now " + std::to_string(c.asked) + ")";
  // The cap binds: below what was asked, or below what a frame needs (unknown cap: assume it does).
  if (c.granted < 2 * c.asked || c.rmem_max < want) {
    const std::string v = std::to_string(want);
    out += std::string(c.asked < want ? "; and raise" : "Raise") + " the kernel's cap (net.core.rmem_max): sudo sysctl -w net.core.rmem_max=" + v +
           " (to keep it: echo net.core.rmem_max=" + v + " | sudo tee /etc/sysctl.d/60-sensor-rig.conf)";
  }
  return out;
}

}  // namespace sensor_rig::camera::detail
