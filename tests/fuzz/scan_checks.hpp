#pragma once
// What every LIDAR fuzz harness asserts, and how its corpus generator writes a file: one place,
// so the invariants cannot drift apart between vendors. Header-only: the corpus generators
// build with a bare g++ line (see each harness's comment).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar::fuzz {

// Finite points, rings below `rings`, and a scan made of at least one packet; abort otherwise.
inline void check_scan(const Scan& s, int rings) {
  for (const auto& p : s.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || p.ring >= rings) std::abort();
  }
  if (s.packets == 0) std::abort();
}

// Every packet pushed is either used or counted as dropped.
template <class Stats>
void check_counters(const Stats& st) {
  if (st.packets != st.packets_used + st.dropped()) std::abort();
}

// A corpus file: the mode byte, then the packets back to back (byte or uint8_t packets).
template <class Byte>
void write_packets(const std::filesystem::path& dir, const std::string& name, std::uint8_t mode,
                   const std::vector<std::vector<Byte>>& packets) {
  std::ofstream f(dir / name, std::ios::binary);
  f.put(static_cast<char>(mode));
  for (const auto& p : packets) f.write(reinterpret_cast<const char*>(p.data()), static_cast<std::streamsize>(p.size()));
}
inline void write_corpus_file(const std::filesystem::path& dir, const std::string& name, std::uint8_t mode,
                              const std::vector<std::vector<std::uint8_t>>& packets) {
  write_packets(dir, name, mode, packets);
}
inline void write_corpus_file(const std::filesystem::path& dir, const std::string& name, std::uint8_t mode,
                              const std::vector<std::vector<std::byte>>& packets) {
  write_packets(dir, name, mode, packets);
}

}  // namespace sensor_rig::lidar::fuzz
