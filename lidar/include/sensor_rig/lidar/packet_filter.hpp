#pragma once
// The classic BPF program the packet-ring source attaches (SO_ATTACH_FILTER) so the kernel copies
// only one sensor's datagrams into the ring, and a userspace interpreter of the instructions it
// uses, so the program is tested without a socket. Pure: no I/O.
//
// The program runs on a SOCK_DGRAM packet socket bound to ETH_P_IP: offsets start at the IPv4
// header. It accepts IPv4 UDP to the sensor's port (or its second port), and every IPv4 UDP fragment (later fragments
// carry no UDP header, so the port cannot be seen: the reassembler and the port check after it
// decide; the datagrams of other ports are then counted as filtered, not lost as timeouts).
// With src_host set, only packets from the sensor's address pass: give it, so other hosts'
// fragments on the link never reach the ring (several sensors on one interface).
#include <linux/filter.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace sensor_rig::lidar {

struct SensorFilter {
  std::uint16_t dst_port = 0;
  std::uint32_t src_host = 0;     // the sensor's IPv4 address, host byte order; 0 = any sender
  std::uint16_t second_port = 0;  // the sensor's other port (IMU / position packets); 0 = none
};

// Bytes the program keeps of an accepted packet (more than any IPv4 datagram).
inline constexpr std::uint32_t kFilterAcceptBytes = 0x40000;

std::vector<sock_filter> build_sensor_filter(const SensorFilter& f);

// Runs a classic BPF program on `packet` the way the kernel would for the instructions
// build_sensor_filter emits (loads past the end reject the packet, as the kernel does). Returns the
// bytes to keep, 0 = rejected; an instruction outside that subset rejects the packet.
std::uint32_t run_classic_bpf(std::span<const sock_filter> program, std::span<const std::byte> packet) noexcept;

}  // namespace sensor_rig::lidar
