#pragma once
// The cameras of a rig: the `cameras:` section (each item drivers/camera's parser, plus the checks
// across items) and, for `rig up`, their nodes, software trigger groups and mock devices.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/camera/camera_driver.hpp"
#include "sensor_rig/drivers/camera/lidar_trigger.hpp"

namespace sensor_rig::rig {

// Parses `cameras:`; duplicate names and devices are problems at their item.
std::vector<drivers::CameraConfig> parse_cameras(const config::Node& root);
std::string describe_cameras(const std::vector<drivers::CameraConfig>& cameras);

// GigE mocks need their address on `lo`: a lease each, appended to `addresses` (removed from the
// host when the last lease on it ends). Where one cannot be added, the camera runs an in-process
// fake instead (logged). Returns the configs as they will run.
std::vector<drivers::CameraConfig> resolve_camera_mocks(std::vector<drivers::CameraConfig> cameras,
                                                        std::vector<LoopbackAddress>& addresses);

class CameraRig {
 public:
  CameraRig(const std::vector<drivers::CameraConfig>& cameras, const dds::Participant& participant,
            dds::StampsWriter& stamps);  // throws when a node cannot be built
  ~CameraRig();
  CameraRig(const CameraRig&) = delete;
  CameraRig& operator=(const CameraRig&) = delete;
  // The LIDAR-triggered cameras' sweep observers, by LIDAR name: `rig up` hands them to those
  // LIDAR drivers before they start.
  [[nodiscard]] std::vector<std::pair<std::string, timesync::SweepObserver*>> sweep_observers() const;
  void start();
  // Restarts GigE fakes that exited (the node reopens its camera by itself); appends statuses.
  void supervise(std::vector<dds::DriverStatus>& statuses);
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::rig
