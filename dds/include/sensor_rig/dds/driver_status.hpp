#pragma once
// What every driver reports for /diagnostics: state, rates, drops, errors, as key/values.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace sensor_rig::dds {

enum class Level : std::uint8_t { kOk = 0, kWarn = 1, kError = 2, kStale = 3 };

struct DriverStatus {
  std::string name;         // e.g. "lidar/front"
  std::string hardware_id;  // e.g. "VLP-16@127.0.0.1:2368"
  Level level = Level::kOk;
  std::string message;      // one line: what is wrong, or "running"
  std::vector<std::pair<std::string, std::string>> values;

  void add(std::string key, std::string value) { values.emplace_back(std::move(key), std::move(value)); }
  template <class T>
  void add_number(std::string key, T v) { values.emplace_back(std::move(key), std::to_string(v)); }
};

}  // namespace sensor_rig::dds
