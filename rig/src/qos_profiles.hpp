#pragma once
// rosbag2's `offered_qos_profiles` channel metadata (a YAML list, one entry per writer of the
// topic) written from what discovery reports, and read back for `rig play` (integer enums as
// Humble/Iron write them, or the names later releases write).
#include <string>
#include <vector>

#include "sensor_rig/dds/qos.hpp"

namespace sensor_rig::rig {

std::string offered_qos_profiles(const std::vector<dds::QosSpec>& writers);
// The first profile of `yaml`; nullopt-like `ok=false` when it is empty or not understood.
struct ParsedQos {
  bool ok = false;
  dds::QosSpec qos;
  std::string why_not;
};
ParsedQos parse_offered_qos_profiles(const std::string& yaml);

}  // namespace sensor_rig::rig
