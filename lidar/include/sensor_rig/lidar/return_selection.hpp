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

}  // namespace sensor_rig::lidar
