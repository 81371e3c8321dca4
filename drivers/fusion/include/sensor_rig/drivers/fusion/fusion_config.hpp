#pragma once
// The fused cloud's configuration (the rig config's `fusion:` section) as a plain struct with
// defaults, and its parser. Every LIDAR of the rig takes part (at most 255); each needs `extrinsics:`.
#include <array>
#include <string>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"

namespace sensor_rig::drivers {

inline constexpr const char* kFusedTopic = "/sensors/lidar/fused/points";
// Each fused sweep's members (sensor_rig_msgs/SyncSet, the synchronizer's type): header.stamp = the
// fused cloud's, set_seq = the fused cloud's seq on /rig/stamps, one member (topic, stamp, seq on
// /rig/stamps) per LIDAR scan it holds. "fused" is reserved as a sync_sets: name for it.
inline constexpr const char* kFusedSetName = "fused";
inline constexpr const char* kFusedSetsTopic = "/rig/sets/fused";

// An axis-aligned box in base_link; points inside it are removed (the ego vehicle: roof rack,
// body, mirrors seen by the LIDARs).
struct CropBoxConfig {
  bool enabled = false;
  std::array<double, 3> min{0, 0, 0};  // x, y, z, metres
  std::array<double, 3> max{0, 0, 0};
};

struct FusionConfig {
  bool enabled = false;
  std::string frame_id = "base_link";
  CropBoxConfig crop_box;
  double voxel_leaf_m = 0.0;  // 0 = no voxel filter
  int timeout_ms = 150;       // a sweep waits at most this long (after its first scan) for the rest
  int max_spread_ms = 100;    // one rotation: the period the LIDARs turn at (sweeps are matched by rotation)
  // SCHED_FIFO priority of the node's thread, 0 = normal: on a busy 2-core PU a normal thread
  // waits behind other work for milliseconds after the last scan arrived.
  int realtime_priority = 0;
  dds::QosSpec qos = lidar_qos();
  // Not in the YAML: where the node logs what its sweep matcher was handed and closed (empty: not
  // logged). `rig up` sets $RIG_LOG_DIR/fusion_matcher.csv: every `rig chaos` campaign keeps it.
  std::string matcher_log;
};

// Parses the `fusion:` map (the rig config checks that every LIDAR has extrinsics).
FusionConfig parse_fusion_config(const config::Node& n);

}  // namespace sensor_rig::drivers
