#pragma once
// The point layout the rig publishes in sensor_msgs/PointCloud2, and the assembled scan.
// Decoders write straight into Scan::points; the DDS publisher hands that buffer to the writer
// as PointCloud2.data without copying (the layout below is the PointField list).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::lidar {

// REP 103 frame (x forward, y left, z up), metres. 24 bytes, little-endian.
struct PointXYZIRT {
  float x;
  float y;
  float z;
  float intensity;
  std::uint32_t t;            // ns after the scan's header.stamp
  std::uint16_t ring;         // laser/channel index, 0 = lowest elevation
  std::uint8_t return_type;   // ReturnType
  std::uint8_t reserved;      // keeps the 24-byte stride; always 0
};
static_assert(sizeof(PointXYZIRT) == 24);
static_assert(offsetof(PointXYZIRT, t) == 16);
static_assert(offsetof(PointXYZIRT, ring) == 20);
static_assert(offsetof(PointXYZIRT, return_type) == 22);

// Which echo a point is; dual-return sensors may mark one point as both.
enum ReturnType : std::uint8_t {
  kReturnUnknown = 0,
  kReturnStrongest = 1,
  kReturnLast = 2,
  kReturnStrongestAndLast = 3,  // dual mode, the same echo was both strongest and last
  kReturnSecondStrongest = 4,
  kReturnFirst = 5,
};

// PointCloud2 field description: name, byte offset, ROS datatype (7 = FLOAT32, 6 = UINT32,
// 4 = UINT16, 2 = UINT8), count.
struct FieldSpec {
  const char* name;
  std::uint32_t offset;
  std::uint8_t datatype;
};
inline constexpr FieldSpec kPointFields[] = {
    {"x", 0, 7},     {"y", 4, 7},     {"z", 8, 7},  {"intensity", 12, 7},
    {"t", 16, 6},    {"ring", 20, 4}, {"return_type", 22, 2},
};

// One complete revolution (or the part between two cut angles).
struct Scan {
  Nanos stamp = 0;                  // vehicle time of the scan's first firing (header.stamp)
  std::vector<PointXYZIRT> points;  // published as-is
  std::uint32_t packets = 0;        // data packets that contributed
  std::uint32_t dropped = 0;        // packets rejected (corrupt, wrong size, out of order) or with a
                                    // corrupted group dropped (implausible azimuth) while assembling
  std::uint32_t missing_packets = 0;  // packets the scan should have had (inside the FOV) and did not
  Nanos first_rx_ns = 0;            // kernel receive time of the first packet (0 if unknown)
  Nanos last_rx_ns = 0;             // kernel receive time of the last packet
  std::uint64_t seq = 0;            // scan counter of this decoder, from 0
};

}  // namespace sensor_rig::lidar
