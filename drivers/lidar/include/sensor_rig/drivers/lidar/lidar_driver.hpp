#pragma once
// One LIDAR: UDP packets (kernel timestamps) -> sensor time -> vehicle time -> decoder -> scan ->
// PointCloud2 on rt/sensors/lidar/<name>/points + SourceStamps on rt/rig/stamps.
// Runs in its own thread; stops when shutdown is requested or stop() is called.
#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/drivers/lidar/scan_observer.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/timesync/sweep_phase.hpp"

namespace sensor_rig::drivers {

class LidarDriver {
 public:
  // Opens sockets and builds the decoder; throws on bad calibration or a port in use.
  LidarDriver(const LidarConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps);
  ~LidarDriver();
  LidarDriver(const LidarDriver&) = delete;
  LidarDriver& operator=(const LidarDriver&) = delete;

  // Each scan's sweep samples (sweep_samples.hpp) go to `o` from the driver thread, before the
  // scan is written (cameras triggered by this sweep: rig/ wires them). Before start(); not owned.
  void add_sweep_observer(timesync::SweepObserver* o);
  // Each published scan goes to `o` after its write (scan_observer.hpp). Before start(); not owned.
  void add_scan_observer(ScanObserver* o);
  void start();
  void stop();
  [[nodiscard]] dds::DriverStatus status() const;
  [[nodiscard]] std::string topic() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::drivers
