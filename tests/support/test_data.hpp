#pragma once
// Where tests find the shared captures and the source tree: one place for every test.
// RIG_TEST_DATA (set by ctest; default ../shared/data beside the clone), RIG_SOURCE_DIR, RIG_BIN.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace sensor_rig::test {

inline std::filesystem::path source_dir() {
  const char* d = std::getenv("RIG_SOURCE_DIR");
  return d != nullptr && *d != '\0' ? std::filesystem::path(d) : std::filesystem::path(".");
}

inline std::filesystem::path data_dir() {
  if (const char* d = std::getenv("RIG_TEST_DATA"); d != nullptr && *d != '\0') return d;
  return source_dir() / "../shared/data";
}

inline std::string rig_bin() {
  const char* b = std::getenv("RIG_BIN");
  return b != nullptr ? b : "build/rig";
}

inline bool exists(const std::filesystem::path& p) { return std::filesystem::exists(p); }

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace sensor_rig::test
