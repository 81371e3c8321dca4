#pragma once
// The raw replay tests' shared parts (raw_replay_test.cpp: LIDAR; raw_replay_can_test.cpp: CAN):
// a recording's LIDAR scans and packets read back, and the fixture with its leased domain and ports.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <span>
#include <sstream>
#include <thread>
#include <utility>

#include "dds_domain_lease.hpp"
#include "record_support.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/bag_metadata.hpp"
#include "sensor_rig/record/mcap_reader.hpp"
#include "sensor_rig/record/mcap_writer.hpp"


namespace sensor_rig::rig::raw_replay {

inline constexpr std::uint32_t kVlp32cPacket = 1206;
inline constexpr std::uint32_t kPositionPacket = 512;
inline constexpr Nanos kScanNs = 100'000'000;  // 600 rpm

inline std::string profile() { return (test::source_dir() / "config/cyclonedds/loopback.xml").string(); }

// FNV-1a, 32 bits, over a payload (as tests/js/mcap_dump.mjs computes it).
inline std::uint32_t fnv1a(std::span<const std::byte> bytes) {
  std::uint32_t h = 0x811c9dc5u;
  for (const auto b : bytes) h = (h ^ std::to_integer<std::uint32_t>(b)) * 0x01000193u;
  return h;
}

struct Recorded {
  std::map<Nanos, std::uint32_t> scans;  // stamp -> points
  std::map<Nanos, std::uint32_t> clouds;  // stamp -> FNV-1a of the cloud's data bytes
  std::uint64_t packets = 0, data_packets = 0, position_packets = 0, batches = 0;
  Nanos first_rx = 0, last_rx = 0;
  // Each VLP data packet in file order: its own time (µs since the hour, the 4 bytes before its
  // last 2: the mock's truth record names a packet by it) and its receipt.
  std::vector<std::pair<std::uint32_t, Nanos>> data;
  std::multiset<std::uint32_t> batch_fnv;  // per message: FNV-1a over its packets' payloads
  std::vector<record::McapProblem> problems;
};

// Our own reading of a file: record/McapReader and dds/cdr_view.
inline Recorded read_recording(const std::string& file, const std::string& lidar) {
  Recorded r;
  record::McapReader reader(file);
  dds::PointCloud2View cloud;
  dds::LidarPacketsView raw;
  reader.for_each_message([&](const record::McapMessage& m) {
    const auto& topic = reader.channels().at(m.channel_id).topic;
    const auto body = dds::cdr_body(m.data);
    if (!body) return true;
    if (topic == "/sensors/lidar/" + lidar + "/points" && dds::parse_cdr(*body, cloud) == dds::CdrStatus::kOk) {
      const Nanos stamp = static_cast<Nanos>(cloud.header.sec) * 1'000'000'000 + cloud.header.nanosec;
      r.scans[stamp] = cloud.width;
      r.clouds[stamp] = fnv1a(cloud.data);
    } else if (topic == "/sensors/lidar/" + lidar + "/packets" && dds::parse_cdr(*body, raw) == dds::CdrStatus::kOk) {
      ++r.batches;
      std::uint32_t fnv = 0x811c9dc5u;
      for (const auto& p : raw.packets) {
        const Nanos rx = static_cast<Nanos>(p.sec) * 1'000'000'000 + p.nanosec;
        if (r.first_rx == 0 || rx < r.first_rx) r.first_rx = rx;
        r.last_rx = std::max(r.last_rx, rx);
        ++r.packets;
        ++(p.dst_port == raw.data_port ? r.data_packets : r.position_packets);
        if (p.dst_port == raw.data_port && p.data.size() == kVlp32cPacket) {
          std::uint32_t us = 0;
          for (std::size_t i = 0; i < 4; ++i) us |= std::to_integer<std::uint32_t>(p.data[kVlp32cPacket - 6 + i]) << (8 * i);
          r.data.emplace_back(us, rx);
        }
        for (const auto b : p.data) fnv = (fnv ^ std::to_integer<std::uint32_t>(b)) * 0x01000193u;
      }
      r.batch_fnv.insert(fnv);
    }
    return true;
  });
  r.problems = reader.problems();
  return r;
}

class RawReplay : public ::testing::Test {
 protected:
  void SetUp() override {
    domain_ = test::lease_dds_domain();
    port_ = test::free_udp_port();
    position_port_ = test::free_udp_port();
  }

  // One VLP-32C named `raw29`, stamped from its packets alone, with the given mock.
  std::string config(const std::string& name, const std::string& mock) const {
    return dir_.write(name, "rig:\n  name: raw-replay\n  dds: {domain: " + std::to_string(domain_) + ", profile: " +
                                profile() + "}\nlidars:\n  - name: raw29\n    model: VLP-32C\n    port: " +
                                std::to_string(port_) + "\n    position_port: " + std::to_string(position_port_) +
                                "\n    time_source: sensor\n    clock_correction: never\n    mock: " + mock + "\n");
  }

  test::RigChild record(const std::vector<std::string>& extra, const std::string& out, double seconds) const {
    std::vector<std::string> args{"record", "--out", out, "--domain", std::to_string(domain_), "--dds-profile", profile(),
                                  "--duration", std::to_string(seconds), "--no-progress"};
    args.insert(args.end(), extra.begin(), extra.end());
    return test::RigChild(args, out + ".out", out + ".err");
  }

  // `line` on the child's stderr within the discovery time (its start line, the transport's close).
  static bool says(test::RigChild& c, const std::string& line) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(test::kDiscoveryMs);
    while (c.err().find(line) == std::string::npos && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return c.err().find(line) != std::string::npos;
  }

  // A split recording's files, `<DIR>_N.mcap` in N order.
  static std::vector<std::string> split_files(const std::string& folder) {
    std::vector<std::pair<long, std::string>> n;
    for (const auto& e : std::filesystem::directory_iterator(folder))
      if (const long i = record::split_file_index(e.path().string()); i >= 0) n.emplace_back(i, e.path().string());
    std::sort(n.begin(), n.end());
    std::vector<std::string> files;
    for (auto& [i, f] : n) files.push_back(f);
    return files;
  }

  test::TempDir dir_;
  int domain_ = 0, port_ = 0, position_port_ = 0;
};

}  // namespace sensor_rig::rig::raw_replay
