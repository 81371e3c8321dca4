#pragma once
// The fused LIDAR cloud: every LIDAR node of the process hands its published scans over
// (ScanObserver, a copy of the points, no DDS in between); the node's thread filters each scan on
// arrival (ScanFilter: base_link, ego crop box, voxels), groups scans into sweeps (SweepMatcher)
// and writes each sweep as one PointCloud2 on rt/sensors/lidar/fused/points + its stamps on
// rt/rig/stamps. A sweep waits for every live LIDAR, or emits the subset it has after timeout_ms;
// a missing LIDAR's scan counts in the stamps' missing_packets.
#include <memory>
#include <string>
#include <vector>

#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/fusion/fusion_config.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/drivers/lidar/scan_observer.hpp"

namespace sensor_rig::drivers {

class FusionNode {
 public:
  // `lidars`: the rig's, in config order (a point's source id is the index); each needs extrinsics.
  FusionNode(const FusionConfig& cfg, const std::vector<LidarConfig>& lidars, const dds::Participant& participant,
             dds::StampsWriter& stamps);
  ~FusionNode();
  FusionNode(const FusionNode&) = delete;
  FusionNode& operator=(const FusionNode&) = delete;

  // What LIDAR `index` hands its scans to (LidarDriver::add_scan_observer); owned by the node.
  [[nodiscard]] ScanObserver* input(std::size_t index);
  void start();
  void stop();  // after the LIDAR nodes stopped (they call into this node)
  [[nodiscard]] dds::DriverStatus status() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::drivers
