#pragma once
// Frame send/receive on a socket carrying kernel CAN structs (SocketCAN raw or AF_UNIX seqpacket).
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can::detail {

// Non-blocking send of one frame; never queues in user space.
IoStatus send_frame(int fd, const Frame& f, TransportStats& stats) noexcept;
// One record from a readable socket (non-blocking); stamp from SO_TIMESTAMPNS, else CLOCK_REALTIME.
IoStatus recv_frame(int fd, RxFrame& out, TransportStats& stats) noexcept;
// poll() for readability; ok, timeout or error.
IoStatus wait_readable(int fd, int timeout_ms) noexcept;
void enable_timestamps(int fd) noexcept;

}  // namespace sensor_rig::dbw::can::detail
