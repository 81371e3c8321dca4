#pragma once
// A device's PPS (pulse per second) lock, as Velodyne position packets report it (byte values
// 0..3) plus kUnknown where no position packet was seen. One enum for the decoder and timesync.
#include <cstdint>

namespace sensor_rig {

enum class PpsState : std::uint8_t { kAbsent = 0, kSynchronizing = 1, kLocked = 2, kError = 3, kUnknown = 4 };

inline constexpr const char* to_string(PpsState p) noexcept {
  switch (p) {
    case PpsState::kAbsent: return "absent";
    case PpsState::kSynchronizing: return "synchronizing";
    case PpsState::kLocked: return "locked";
    case PpsState::kError: return "error";
    case PpsState::kUnknown: return "unknown";
  }
  return "?";
}

}  // namespace sensor_rig
