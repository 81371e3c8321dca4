#pragma once
// Frame send/receive on a socket carrying kernel CAN structs (SocketCAN raw or AF_UNIX seqpacket),
// and the sockets' options: through common/socket_options, one error style for every socket.
#include <string_view>

#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can::detail {

// Non-blocking send of one frame; never queues in user space.
IoStatus send_frame(int fd, const Frame& f, TransportStats& stats) noexcept;
// One record from a readable socket (non-blocking); stamp from SO_TIMESTAMPNS, else CLOCK_REALTIME.
IoStatus recv_frame(int fd, RxFrame& out, TransportStats& stats) noexcept;
// poll() for readability; ok, timeout or error.
IoStatus wait_readable(int fd, int timeout_ms) noexcept;

// An option the transport cannot work without. Throws TransportError "<owner>: setsockopt <name>: <errno text>".
void require_option(int fd, int level, int opt, int value, const char* name, std::string_view owner);
// An option it can live without: on failure it is counted (stats.options_refused, stats.last_errno)
// and logged as a warning with the errno text and what the transport does `without` it; false then.
bool optional_option(int fd, int level, int opt, int value, const char* name, std::string_view owner,
                     std::string_view without, TransportStats& stats) noexcept;
// Kernel receive stamps (SO_TIMESTAMPNS), optional: without them recv_frame stamps on receipt.
bool enable_timestamps(int fd, std::string_view owner, TransportStats& stats) noexcept;

}  // namespace sensor_rig::dbw::can::detail
