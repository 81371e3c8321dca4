#pragma once
// The field table of every supported Ouster lidar UDP profile, indexed by Profile (bit positions
// from the sensor firmware manual; the same layout ouster-sdk's parsing.cpp encodes). Private:
// profile_spec() is the public way in; the decoder reads it at compile time for its column loops.
#include <iterator>

#include "sensor_rig/lidar/ouster/profile.hpp"

namespace sensor_rig::lidar::ouster {

inline constexpr FieldSpec bits(std::uint16_t bit, std::uint8_t width, std::uint8_t up = 0) { return {bit, width, up}; }
inline constexpr FieldSpec kNone{};

// Order of every table: range, flags, reflectivity, signal, near_ir, range2, flags2,
// reflectivity2, signal2, window (the Field enum).
inline constexpr ProfileSpec kProfileTable[] = {
    {Profile::kLegacy, "LEGACY", 12, 1,
     {bits(0, 20), bits(28, 4), bits(32, 8), bits(48, 16), bits(64, 16), kNone, kNone, kNone, kNone, kNone}},
    {Profile::kRng19Rfl8Sig16Nir16, "RNG19_RFL8_SIG16_NIR16", 12, 1,
     {bits(0, 19), bits(19, 5), bits(32, 8), bits(48, 16), bits(64, 16), kNone, kNone, kNone, kNone, bits(88, 8)}},
    {Profile::kRng19Rfl8Sig16Nir16Dual, "RNG19_RFL8_SIG16_NIR16_DUAL", 16, 2,
     {bits(0, 19), bits(19, 5), bits(24, 8), bits(64, 16), bits(96, 16), bits(32, 19), bits(51, 5), bits(56, 8), bits(80, 16), bits(120, 8)}},
    {Profile::kRng15Rfl8Nir8, "RNG15_RFL8_NIR8", 4, 1,
     {bits(0, 15, 3), bits(15, 1), bits(16, 8), kNone, bits(24, 8, 4), kNone, kNone, kNone, kNone, kNone}},
    {Profile::kRng15Rfl8Win8, "RNG15_RFL8_WIN8", 4, 1,
     {bits(0, 15, 3), bits(15, 1), bits(16, 8), kNone, kNone, kNone, kNone, kNone, kNone, bits(24, 8)}},
    {Profile::kFiveWordPixel, "FIVE_WORD_PIXEL", 20, 2,
     {bits(0, 19), bits(19, 5), bits(24, 8), bits(64, 16), bits(96, 16), bits(32, 19), bits(51, 5), bits(56, 8), bits(80, 16), kNone}},
    {Profile::kFusaRng15Rfl8Nir8Dual, "FUSA_RNG15_RFL8_NIR8_DUAL", 8, 2,
     {bits(0, 15, 3), bits(15, 1), bits(16, 8), kNone, bits(24, 8, 4), bits(32, 15, 3), bits(47, 1), bits(48, 8), kNone, bits(56, 8)}},
    {Profile::kRng15Rfl8Nir8Dual, "RNG15_RFL8_NIR8_DUAL", 8, 2,
     {bits(0, 15, 3), bits(15, 1), bits(16, 8), kNone, bits(24, 8, 4), bits(32, 15, 3), bits(47, 1), bits(48, 8), kNone, bits(56, 8)}},
};
static_assert(std::size(kProfileTable) == kProfileCount);

// Entry i describes Profile i (profile_spec() and the decoder index the table by the enum).
constexpr bool table_in_enum_order() {
  for (std::size_t i = 0; i < kProfileCount; ++i)
    if (static_cast<std::size_t>(kProfileTable[i].profile) != i) return false;
  return true;
}
static_assert(table_in_enum_order());

}  // namespace sensor_rig::lidar::ouster
