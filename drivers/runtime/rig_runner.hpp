#pragma once
// `rig up`: starts the drivers a config names (and their mock devices when the config asks for
// them), publishes diagnostics, and stops everything cleanly on SIGINT/SIGTERM or after a duration.
#include "rig_config.hpp"

namespace sensor_rig::runtime {

struct RunOptions {
  double duration_s = 0;  // 0 = until a signal
};

// Returns the exit code: 0 after a clean stop, 1 when a driver could not start.
int run_rig(const RigConfig& cfg, const RunOptions& opt);

// argv of the mock process for a LIDAR (`rig lidar replay ...`), empty when it has none.
std::vector<std::string> lidar_mock_command(const std::string& rig_exe, const LidarConfig& l);
// argv of the drive-by-wire processes, in start order: mock ECU, bridge, command source.
std::vector<std::vector<std::string>> dbw_commands(const std::string& rig_exe, const DbwConfig& d);

}  // namespace sensor_rig::runtime
