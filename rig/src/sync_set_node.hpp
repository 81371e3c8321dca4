#pragma once
// The set node of `rig up`: reads /rig/stamps (topic, header.stamp, seq of every sample the rig
// publishes: never the big samples themselves), runs one timesync::Synchronizer per configured set
// and publishes each complete set on /rig/sets/<name>. Its counters go to /diagnostics as
// rig/sets/<name>: sets, incomplete, dropped (per member), late, timeouts, spread p50/p99/max.
#include <memory>
#include <vector>

#include "sensor_rig/dds/driver_status.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sync_sets_config.hpp"

namespace sensor_rig::rig {

class SyncSetNode {
 public:
  SyncSetNode(const std::vector<SyncSetConfig>& sets, const dds::Participant& participant);  // throws
  ~SyncSetNode();
  SyncSetNode(const SyncSetNode&) = delete;
  SyncSetNode& operator=(const SyncSetNode&) = delete;
  void start();
  void stop();
  // Appends one status per set (thread-safe; call from the diagnostics loop).
  void supervise(std::vector<dds::DriverStatus>& statuses);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::rig
