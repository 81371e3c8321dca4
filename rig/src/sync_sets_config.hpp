#pragma once
// `sync_sets:` of the rig config: synchronized sets the rig publishes on /rig/sets/<name>.
//   sync_sets:
//     - name: stereo
//       members: [/sensors/camera/stereo_left/image_raw, /sensors/camera/stereo_right/image_raw]
//       policy: approximate        # exact | approximate
//       max_spread_ms: 5           # approximate: latest - earliest member stamp
//       timeout_ms: 300            # how long a set waits for its last member (arrival time)
//       min_interval_ms: 50        # optional: members' next stamp is at least this later (0 = unknown)
// Members must be topics this rig publishes (with stamps on /rig/stamps); names are unique.
#include <set>
#include <string>
#include <vector>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/dbw/dbw_config.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/timesync/synchronizer.hpp"

namespace sensor_rig::rig {

struct SyncSetConfig {
  std::string name;
  std::vector<std::string> members;  // ROS topic names
  timesync::SyncPolicy policy = timesync::SyncPolicy::kApproximate;
  double max_spread_ms = 10;
  double timeout_ms = 500;
  double min_interval_ms = 0;

  [[nodiscard]] timesync::SyncConfig synchronizer_config() const;
  [[nodiscard]] std::string topic() const { return "/rig/sets/" + name; }
};

// The topics a rig config publishes with per-sample stamps (the possible set members).
std::set<std::string> stamped_topics(const std::vector<drivers::LidarConfig>& lidars,
                                     const std::vector<drivers::CameraConfig>& cameras, const drivers::DbwConfig& dbw);

// Reports every problem into root's Problems (file:line:col), returns what parsed.
std::vector<SyncSetConfig> parse_sync_sets(const config::Node& root, const std::set<std::string>& known_topics);

std::string describe_sync_sets(const std::vector<SyncSetConfig>& sets);

}  // namespace sensor_rig::rig
