#pragma once
// Signal encode/decode on frames of up to 64 bytes. No allocation, no exceptions:
// the hot path returns a status.
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "sensor_rig/dbw/dbc/database.hpp"

namespace sensor_rig::dbw::dbc {

inline constexpr std::size_t kMaxFrameBytes = 64;

// Bit positions (byte*8 + bit-in-byte, bit 0 = LSB) a signal occupies, MSB first for Motorola and
// LSB first for Intel. Returns false when a bit falls outside `frame_bytes`.
[[nodiscard]] bool signal_fits(const Signal& s, std::size_t frame_bytes) noexcept;
// Number of bytes a signal needs (its highest bit / 8 + 1), or 0 if the layout is invalid.
[[nodiscard]] std::size_t signal_extent(const Signal& s) noexcept;

// Raw (unscaled) bits of the signal; nullopt when the data is too short.
[[nodiscard]] std::optional<std::uint64_t> extract_raw(const Signal& s, std::span<const std::uint8_t> data) noexcept;
// Writes raw bits; false when the data is too short (nothing written then).
bool insert_raw(const Signal& s, std::uint64_t raw, std::span<std::uint8_t> data) noexcept;

// Physical value = raw (sign-extended, or IEEE float) * factor + offset.
[[nodiscard]] std::optional<double> decode(const Signal& s, std::span<const std::uint8_t> data) noexcept;
[[nodiscard]] double to_physical(const Signal& s, std::uint64_t raw) noexcept;

enum class EncodeStatus : std::uint8_t { kOk, kClamped, kNotFinite, kOutOfFrame };
// Physical -> raw, rounded to the nearest step, clamped to what the bits can hold (reported).
[[nodiscard]] EncodeStatus to_raw(const Signal& s, double physical, std::uint64_t& raw) noexcept;
EncodeStatus encode(const Signal& s, double physical, std::span<std::uint8_t> data) noexcept;

// Is this signal present in the frame (multiplexing)? Non-multiplexed: always.
[[nodiscard]] bool signal_active(const Message& m, const Signal& s, std::span<const std::uint8_t> data) noexcept;

// The physical value as text with the signal's natural precision ("28.86", "-0.4", "5").
[[nodiscard]] std::string format_value(const Signal& s, double physical);

}  // namespace sensor_rig::dbw::dbc
