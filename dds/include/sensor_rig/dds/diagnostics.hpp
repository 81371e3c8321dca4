#pragma once
// Publishes every driver's status on rt/diagnostics (diagnostic_msgs/DiagnosticArray) periodically.
#include <functional>
#include <vector>

#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::dds {

class DiagnosticsPublisher {
 public:
  explicit DiagnosticsPublisher(const dds::Participant& p);
  void publish(const std::vector<DriverStatus>& statuses);

 private:
  dds::Topic<msg::DiagnosticArray> topic_;
  dds::Writer<msg::DiagnosticArray> writer_;
};

}  // namespace sensor_rig::dds
