#include "node_io.hpp"

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

namespace sensor_rig::bench::perf {

void announce_ready() {
  std::fputs("READY\n", stdout);
  std::fflush(stdout);
}

std::optional<Nanos> wait_for_start() {
  std::string line;
  while (std::getline(std::cin, line)) {
    if (line.rfind("START ", 0) == 0) {
      char* end = nullptr;
      const long long t0 = std::strtoll(line.c_str() + 6, &end, 10);
      if (end != nullptr && *end == '\0' && t0 > 0) return static_cast<Nanos>(t0);
      return std::nullopt;
    }
    if (line == "STOP") return std::nullopt;
  }
  return std::nullopt;
}

void StopWatcher::watch() {
  std::string line;
  while (std::getline(std::cin, line)) {
    if (line == "STOP") return;
  }
}

}  // namespace sensor_rig::bench::perf
