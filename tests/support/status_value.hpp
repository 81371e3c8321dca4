#pragma once
// One key of a node's /diagnostics status, as tests read it.
#include <string>

#include "sensor_rig/dds/driver_status.hpp"

namespace sensor_rig::test {

// The value of `key`, or "<absent>" (a string no status carries, so a comparison fails visibly).
inline std::string status_value(const dds::DriverStatus& s, const std::string& key) {
  for (const auto& [k, v] : s.values)
    if (k == key) return v;
  return "<absent>";
}

}  // namespace sensor_rig::test
