#pragma once
// Which echoes a decoder keeps: one enum for every vendor, parsed once where text comes in
// (config, CLI), never compared as a string per packet.
#include <cstdint>
#include <optional>
#include <string_view>

namespace sensor_rig::lidar {

enum class ReturnSelection : std::uint8_t { kStrongest, kLast, kDual };

inline constexpr const char* to_string(ReturnSelection r) noexcept {
  switch (r) {
    case ReturnSelection::kStrongest: return "strongest";
    case ReturnSelection::kLast: return "last";
    case ReturnSelection::kDual: return "dual";
  }
  return "?";
}

// "strongest" | "last" | "dual"; nullopt for anything else.
inline std::optional<ReturnSelection> parse_return_selection(std::string_view s) noexcept {
  for (auto r : {ReturnSelection::kStrongest, ReturnSelection::kLast, ReturnSelection::kDual})
    if (s == to_string(r)) return r;
  return std::nullopt;
}

// Velodyne: the azimuth of a point inside a block. kPerLaser (default, the manuals' "precision
// azimuth" and the ROS driver): each laser interpolated by its own firing time. kPerSequence
// (VeloView): per firing sequence (VLP-16 second sequence at half the block step, all else at the
// block azimuth).
enum class AzimuthInterpolation : std::uint8_t { kPerSequence, kPerLaser };

inline constexpr const char* to_string(AzimuthInterpolation a) noexcept {
  return a == AzimuthInterpolation::kPerLaser ? "per-laser" : "per-sequence";
}
// "per-laser" | "per-sequence"; nullopt for anything else.
inline std::optional<AzimuthInterpolation> parse_azimuth_interpolation(std::string_view s) noexcept {
  for (auto a : {AzimuthInterpolation::kPerLaser, AzimuthInterpolation::kPerSequence})
    if (s == to_string(a)) return a;
  return std::nullopt;
}

}  // namespace sensor_rig::lidar
