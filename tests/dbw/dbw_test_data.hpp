#pragma once
// Locating the shared captures (RIG_TEST_DATA) and the source tree (RIG_SOURCE_DIR) from tests.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace sensor_rig::dbw::test {

inline std::filesystem::path data_dir() {
  if (const char* d = std::getenv("RIG_TEST_DATA"); d != nullptr && *d != '\0') return d;
  if (const char* s = std::getenv("RIG_SOURCE_DIR"); s != nullptr && *s != '\0') {
    return std::filesystem::path(s) / "../shared/data";
  }
  return std::filesystem::path("../shared/data");
}

inline std::filesystem::path source_dir() {
  const char* d = std::getenv("RIG_SOURCE_DIR");
  return d != nullptr ? std::filesystem::path(d) : std::filesystem::path(".");
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace sensor_rig::dbw::test
