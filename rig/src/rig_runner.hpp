#pragma once
// `rig up`: starts the drivers a config names (and their mock devices when the config asks for
// them), publishes diagnostics, and stops everything cleanly on SIGINT/SIGTERM or after a duration.
#include <filesystem>
#include <string>
#include <vector>

#include "rig_config.hpp"

namespace sensor_rig::rig {

struct RunOptions {
  double duration_s = 0;  // 0 = until a signal
};

// Returns the exit code: 0 after a clean stop, 1 when a driver could not start.
int run_rig(const RigConfig& cfg, const RunOptions& opt);

// Where `rig up` writes the metadata of synthetic Ouster mocks that have none configured:
// $RIG_LOG_DIR (kept), else a fresh temporary directory removed when the rig stops.
class SyntheticMetadataDir {
 public:
  SyntheticMetadataDir();  // throws std::runtime_error
  ~SyntheticMetadataDir();
  SyntheticMetadataDir(const SyntheticMetadataDir&) = delete;
  SyntheticMetadataDir& operator=(const SyntheticMetadataDir&) = delete;
  // Writes <dir>/<name>_synthetic_metadata.json (the nominal OS-1 the mock renders for this
  // config: rpm 600/1200 -> 1024x10/1024x20, udp_port_lidar = the config's port); returns its path.
  [[nodiscard]] std::string write(const LidarConfig& l) const;
  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::filesystem::path path_;
  bool owned_ = false;
};
// True for a synthetic Ouster mock without metadata (the runner writes it, see above).
bool needs_synthetic_metadata(const LidarConfig& l);

// argv of the mock process for a LIDAR (`rig lidar replay ...`), empty when it has none.
std::vector<std::string> lidar_mock_command(const std::string& rig_exe, const LidarConfig& l);
// argv of the drive-by-wire processes, in start order: mock ECU, bridge, command source; `domain`
// (>= 0) is passed to the bridge and the command source as --domain.
std::vector<std::vector<std::string>> dbw_commands(const std::string& rig_exe, const DbwConfig& d, int domain = -1);

}  // namespace sensor_rig::rig
