#pragma once
#include <stdexcept>
#include <string>

namespace sensor_rig {

// Configuration problem: names the file, line and key. Maps to exit code 2.
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace sensor_rig
