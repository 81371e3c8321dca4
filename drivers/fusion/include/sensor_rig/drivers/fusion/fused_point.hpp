#pragma once
// The fused cloud's point (/sensors/lidar/fused/points, frame base_link): 24 bytes, little-endian.
#include <cstddef>
#include <cstdint>

#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::drivers {

struct FusedPoint {
  float x;
  float y;
  float z;
  float intensity;
  std::uint32_t t;        // ns after the fused cloud's header.stamp (its earliest scan's stamp)
  std::uint16_t source;   // the LIDAR: its index in the rig config's lidars: list
  std::uint16_t reserved; // keeps the 24-byte stride; always 0
};
static_assert(sizeof(FusedPoint) == 24);
static_assert(offsetof(FusedPoint, t) == 16);
static_assert(offsetof(FusedPoint, source) == 20);

inline constexpr lidar::FieldSpec kFusedPointFields[] = {
    {"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}, {"t", 16, 6}, {"source", 20, 4},
};

}  // namespace sensor_rig::drivers
