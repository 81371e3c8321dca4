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
  if (d != nullptr && *d != '\0') return d;
#ifdef RIG_DEFAULT_SOURCE_DIR
  return RIG_DEFAULT_SOURCE_DIR;  // the checkout this test was built from (cmake/RigTargets.cmake)
#else
  return ".";
#endif
}

inline std::filesystem::path data_dir() {
  if (const char* d = std::getenv("RIG_TEST_DATA"); d != nullptr && *d != '\0') return d;
#ifdef RIG_DEFAULT_TEST_DATA
  return RIG_DEFAULT_TEST_DATA;
#else
  return source_dir() / "../shared/data";
#endif
}

inline std::string rig_bin() {
  const char* b = std::getenv("RIG_BIN");
  if (b != nullptr && *b != '\0') return b;
#ifdef RIG_DEFAULT_BIN
  return RIG_DEFAULT_BIN;
#else
  return "build/rig";
#endif
}

inline bool exists(const std::filesystem::path& p) { return std::filesystem::exists(p); }

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace sensor_rig::test
