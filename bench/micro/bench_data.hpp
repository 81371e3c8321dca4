#pragma once
// Where the micro-benchmarks find the shared captures: $RIG_TEST_DATA, else the build's default
// (../shared/data beside the clone). One helper for every bench_* main.
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace sensor_rig::bench {

inline std::string data_dir() {
  const char* d = std::getenv("RIG_TEST_DATA");
  return d != nullptr && *d != '\0' ? d : RIG_TEST_DATA_DEFAULT;
}

// Defined by each benchmark that links bench_main.cpp: registers its cases at start-up.
void register_benchmarks();

inline std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace sensor_rig::bench
