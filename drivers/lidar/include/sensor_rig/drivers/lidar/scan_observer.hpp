#pragma once
// Another node in the same process that takes every scan a LIDAR node publishes (the fused
// cloud): called from the LIDAR's driver thread right after the scan's DDS write returned, with
// the scan as published. The points are the driver's buffer, valid only during the call: copy
// what is needed and return quickly (the next packets wait in the socket meanwhile).
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::drivers {

class ScanObserver {
 public:
  virtual ~ScanObserver() = default;
  // `written_ns`: vehicle time the scan's write returned (it is on the wire). `stamp_unsynchronized`:
  // the LIDAR's topic was flagged `stamp_sync: unsynchronized` as this scan went out (its stamp may
  // not name its first firing): whatever takes its stamp over inherits the warning.
  virtual void observe_scan(const lidar::Scan& scan, Nanos written_ns, bool stamp_unsynchronized) = 0;

 protected:
  ScanObserver() = default;
  ScanObserver(const ScanObserver&) = default;
  ScanObserver& operator=(const ScanObserver&) = default;
};

}  // namespace sensor_rig::drivers
