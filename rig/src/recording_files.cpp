#include "recording_files.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <utility>

#include "sensor_rig/record/bag_metadata.hpp"

namespace sensor_rig::rig {

std::vector<std::string> recording_files(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(path, ec)) return {path};
  std::vector<std::string> listed;
  const fs::path metadata = fs::path(path) / "metadata.yaml";
  if (fs::exists(metadata, ec)) {
    try {
      for (const auto& f : YAML::LoadFile(metadata.string())["rosbag2_bagfile_information"]["relative_file_paths"])
        listed.push_back((fs::path(path) / f.as<std::string>()).lexically_normal().string());
    } catch (const YAML::Exception& e) {
      throw std::runtime_error(metadata.string() + ": " + e.what());
    }
  }
  std::vector<std::pair<long, std::string>> unlisted;
  for (const auto& e : fs::directory_iterator(path, ec)) {
    const std::string file = e.path().lexically_normal().string();
    const long n = record::split_file_index(file);
    if (n >= 0 && std::find(listed.begin(), listed.end(), file) == listed.end()) unlisted.emplace_back(n, file);
  }
  std::sort(unlisted.begin(), unlisted.end());
  for (auto& [n, file] : unlisted) listed.push_back(std::move(file));
  if (listed.empty()) throw std::runtime_error(path + ": a folder without a split recording (no metadata.yaml, no " +
                                               fs::path(path).filename().string() + "_N.mcap)");
  return listed;
}

}  // namespace sensor_rig::rig
