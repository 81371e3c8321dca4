#pragma once
// A VLP-16 mock (`rig lidar replay --synthetic VLP-16`) run as `rig up` runs it under `rig chaos`
// (a MockProcess MockFaults may kill and restart), sending to a loopback socket whose every
// datagram is read with its sensor time and when it arrived: the truth a host fault's test holds the
// mock's stream against.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mock_faults.hpp"
#include "rig_cli.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/udp_source.hpp"

namespace sensor_rig::test {

constexpr std::size_t kVelodynePacket = 1206, kVelodyneTimeAt = 1200;  // µs since the hour, little endian

inline std::uint32_t velodyne_sensor_us(std::span<const std::byte> b) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | std::to_integer<std::uint32_t>(b[kVelodyneTimeAt + static_cast<std::size_t>(i)]);
  return v;
}

class VelodyneMockReceiver {
 public:
  struct Rx {
    std::size_t bytes = 0;
    std::uint32_t sensor_us = 0;  // 0 unless a whole Velodyne packet
    Nanos mono = 0;               // when the test read it
  };

  VelodyneMockReceiver() : source_(loopback()), arena_(64) {}

  // The mock's argv: `rig lidar replay --synthetic VLP-16` to this socket, then `extra`.
  std::vector<std::string> mock_argv(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> argv{rig_bin_or_empty(), "lidar", "replay", "--synthetic", "VLP-16", "--to",
                                  "127.0.0.1:" + std::to_string(source_.port())};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  }
  // The mock as a device "front" of `rig up`, its output in `log_file`.
  std::vector<rig::MockProcess> start_front(const std::vector<std::string>& argv, const std::string& log_file) const {
    ChildOptions co;
    co.log_file = log_file;
    std::vector<rig::MockProcess> mocks;
    mocks.push_back(rig::MockProcess{"front", argv, co, ChildProcess(argv, co)});
    return mocks;
  }
  // What arrived within timeout_ms (empty: nothing).
  std::vector<Rx> receive(int timeout_ms) {
    std::vector<Rx> out;
    const lidar::RecvResult r = source_.receive(arena_.slots(), timeout_ms);
    for (std::size_t i = 0; i < r.count; ++i) {
      const auto b = arena_.slots()[i].bytes();
      out.push_back({b.size(), b.size() == kVelodynePacket ? velodyne_sensor_us(b) : 0, monotonic_now_ns()});
    }
    return out;
  }
  const lidar::UdpSource& source() const { return source_; }

 private:
  static lidar::UdpSourceConfig loopback() {
    lidar::UdpSourceConfig cfg;
    cfg.bind = {"127.0.0.1", 0};
    cfg.receive_buffer_bytes = 16 << 20;
    return cfg;
  }
  lidar::UdpSource source_;
  lidar::SlotArena arena_;
};

}  // namespace sensor_rig::test
