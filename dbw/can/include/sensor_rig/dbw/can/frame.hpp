#pragma once
// One CAN frame (CAN 2.0 or CAN FD), independent of any socket API, plus the conversion to and
// from the kernel's `struct can_frame` / `struct canfd_frame` bytes (what SocketCAN and the
// socketpair transport carry).
#include <array>
#include <cstdint>
#include <optional>
#include <span>

namespace sensor_rig::dbw::can {

inline constexpr std::size_t kClassicMaxLen = 8;
inline constexpr std::size_t kFdMaxLen = 64;
inline constexpr std::uint32_t kStandardIdMask = 0x7FFU;
inline constexpr std::uint32_t kExtendedIdMask = 0x1FFFFFFFU;

struct Frame {
  std::uint32_t id = 0;  // 11 or 29 bits (error frames: the error class bits)
  std::uint8_t len = 0;  // data bytes, 0..8 (classic) or 0..64 (FD)
  bool extended = false;
  bool rtr = false;
  bool error = false;
  bool fd = false;
  bool brs = false;  // FD bit-rate switch
  bool esi = false;  // FD error state indicator
  std::array<std::uint8_t, kFdMaxLen> data{};

  [[nodiscard]] std::span<const std::uint8_t> payload() const noexcept { return {data.data(), len}; }
  [[nodiscard]] std::span<std::uint8_t> payload() noexcept { return {data.data(), len}; }
  friend bool operator==(const Frame& a, const Frame& b) noexcept;
};

// Valid CAN FD payload lengths are 0..8, 12, 16, 20, 24, 32, 48, 64.
[[nodiscard]] bool valid_fd_length(std::size_t len) noexcept;

// Kernel wire sizes (CAN_MTU, CANFD_MTU).
inline constexpr std::size_t kClassicWireSize = 16;
inline constexpr std::size_t kFdWireSize = 72;

enum class WireStatus : std::uint8_t { kOk, kBadSize, kBadLength, kBadId };
// Writes the kernel struct bytes of `f` into `out` (>= 72 bytes); returns the size used (16 or 72), 0 on error.
std::size_t to_wire(const Frame& f, std::span<std::uint8_t> out) noexcept;
// Parses kernel struct bytes (16 = can_frame, 72 = canfd_frame).
WireStatus from_wire(std::span<const std::uint8_t> in, Frame& out) noexcept;

}  // namespace sensor_rig::dbw::can
