#pragma once
// rosbag2's `metadata.yaml` for a folder of MCAP files (a split recording), so that `ros2 bag info`
// and `ros2 bag play` take the folder as one bag. Written as rosbag2's metadata version 5 (Humble's):
// the first version with per-file entries (`files`), and the newest that every rosbag2 since Humble
// reads. Humble reads `offered_qos_profiles` as a string (versions 4-8); version 9 (Jazzy) makes it a
// YAML list, which Humble's reader refuses; Jazzy and later read versions < 9 through their
// string path. Versions 6-8 only add fields (custom_data, type_description_hash, ros_distro) that
// the rig has no truthful value for.
#include <cstdint>
#include <string>
#include <vector>

namespace sensor_rig::record {

struct BagFileInfo {
  std::string path;  // relative to the folder (rosbag2 >= version 4 resolves it so)
  std::uint64_t start_ns = 0, end_ns = 0, messages = 0;  // log times of the file's first and last message
};

struct BagTopicInfo {
  std::string name;                   // ROS name
  std::string type;                   // "sensor_msgs/msg/PointCloud2"
  std::string serialization_format;   // "cdr"
  std::string offered_qos_profiles;   // the channel's metadata: rosbag2's YAML, as a string
  std::uint64_t messages = 0;
};

inline constexpr int kBagMetadataVersion = 5;

// The YAML text of `metadata.yaml` (storage_identifier mcap; compression_format and _mode empty:
// MCAP's chunk compression is inside the storage, and a non-empty format makes rosbag2 decompress
// the files themselves).
std::string bag_metadata_yaml(const std::vector<BagFileInfo>& files, const std::vector<BagTopicInfo>& topics);

// Writes `folder/metadata.yaml` atomically (a temporary file renamed over it, so a reader or a kill
// never sees half of it). Throws McapError.
void write_bag_metadata(const std::string& folder, const std::vector<BagFileInfo>& files,
                        const std::vector<BagTopicInfo>& topics);

// A split recording's file: `DIR/<DIR>_N.mcap` (as SplitWriter names them); N, or -1 when `file` is not one.
long split_file_index(const std::string& file);

struct BagRefresh {
  std::vector<std::string> listed;   // the files metadata.yaml now names, in N order
  std::vector<std::string> skipped;  // "NAME: why" for each `<DIR>_N.mcap` left out (no summary: not repaired)
};

// Rewrites `folder/metadata.yaml` from the files themselves (after `rig record repair` of one of
// them): every `<DIR>_N.mcap` in N order that is complete with a Statistics record in its summary,
// its count and first/last log time from that record, the topics (name, schema name, message
// encoding, the channel's offered_qos_profiles) with their counts summed over the files, in the order
// they first appear; channels without messages are left out, as SplitWriter leaves them. A file that
// is not complete (a killed writer's, not repaired) is skipped and named, as SplitWriter never lists
// it. Throws McapError when metadata.yaml cannot be written.
BagRefresh refresh_bag_metadata(const std::string& folder);

}  // namespace sensor_rig::record
