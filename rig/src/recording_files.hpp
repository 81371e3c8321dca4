#pragma once
// The files of a recording, in the order they play: one file, or the folder `rig record --split-*`
// (and `ros2 bag record`) writes. Shared by `rig play` and the raw channel replays (LIDAR, CAN).
#include <string>
#include <vector>

namespace sensor_rig::rig {

// The files its metadata.yaml lists, in its order, then any `<DIR>_N.mcap` it does not list in N
// order (a killed recorder's last file, or all of them when it died in the first). A path that is
// not a folder is the one file. Throws std::runtime_error for a folder with no recording file or an
// unreadable metadata.yaml.
std::vector<std::string> recording_files(const std::string& path);

}  // namespace sensor_rig::rig
