#pragma once
// The GigE stream's receive buffer as the kernel really grants it (issue 27 item 4): Aravis sets
// SO_RCVBUF on its stream socket, and the kernel silently caps it at net.core.rmem_max (208 kB on
// a stock host), where a 1920x1200 frame lost ~92 % of its packets. Aravis does not report the
// granted size, so a socket of this process asks the same size and reads back what it got: the
// same request under the same privileges and limits. Nothing of the host is changed.
#include <cstddef>
#include <cstdint>
#include <string>

namespace sensor_rig::camera::detail {

struct SocketBufferCheck {
  std::int64_t asked = 0;    // what the config asks Aravis for (socket_buffer_bytes)
  std::int64_t granted = 0;  // SO_RCVBUF read back (the kernel reports twice the usable request); 0: not known
  std::int64_t needed = 0;   // one frame in flight at the kernel's accounting (~2 bytes per payload byte)
  std::int64_t rmem_max = 0; // net.core.rmem_max as read (0: not readable): the cap on any request
  [[nodiscard]] bool short_of_frame() const noexcept { return granted > 0 && granted < needed; }
};

// Asks a UDP socket for `asked` bytes of receive buffer and reads back the grant.
SocketBufferCheck check_socket_buffer(std::int64_t asked, std::size_t frame_payload_bytes) noexcept;

// The WARN line: the granted size, what a frame needs, and the commands that raise the cap.
std::string socket_buffer_advice(const std::string& device, const SocketBufferCheck& c);

}  // namespace sensor_rig::camera::detail
