#pragma once
// Socket options and receive control data, one way for every socket of the rig (LIDAR UDP,
// CAN): setup errors throw std::system_error naming the option; kernel receive timestamps
// (SO_TIMESTAMPNS), the receive-queue drop counter (SO_RXQ_OVFL) and the datagram's destination
// address (IP_PKTINFO) come out of one parser.
#include <sys/socket.h>

#include <cstdint>
#include <optional>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig {

// setsockopt(fd, level, opt, int value); throws std::system_error("setsockopt <name>") on failure.
void set_socket_option(int fd, int level, int opt, int value, const char* name);
// The same for options a socket can live without (privileged sizes, optional stamps): false on failure.
bool try_socket_option(int fd, int level, int opt, int value) noexcept;

struct ReceiveControl {
  Nanos kernel_rx_ns = 0;                    // SCM_TIMESTAMPNS (CLOCK_REALTIME); 0 when absent
  std::optional<std::uint32_t> rxq_dropped;  // SO_RXQ_OVFL: the socket's drop count so far
  std::optional<std::uint32_t> dst_addr;     // IP_PKTINFO: the IPv4 header's destination, host byte order
};

// Control messages of one received datagram (recvmsg / recvmmsg's msg_hdr).
ReceiveControl read_receive_control(const msghdr& h) noexcept;

}  // namespace sensor_rig
