#pragma once
// `rig lidar replay --mcap FILE --mcap-topic TOPIC`: a LIDAR's raw channel recorded by `rig record
// --raw` (sensor_rig_msgs/msg/LidarPackets, docs/recording.md "Raw channels") as a packet stream,
// each datagram at its recorded kernel receive time, the second port's (dst_port != the recorded
// data_port) marked as position packets. A reader thread decompresses and decodes up to 32 MiB
// ahead, so the paced sender only pops. A damaged file (cut, corrupt chunk, undecodable message)
// plays what is intact; error() then names each place by its byte offset.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/lidar/mock/replay.hpp"

namespace sensor_rig::record {
class McapReader;
}

namespace sensor_rig::rig {

class McapPacketStream final : public lidar::mock::PacketStream {
 public:
  // Throws std::runtime_error when the file is not MCAP or has no LidarPackets channel `topic`
  // (the message names the LidarPackets channels it has).
  McapPacketStream(std::string path, std::string topic);
  ~McapPacketStream() override;
  McapPacketStream(const McapPacketStream&) = delete;
  McapPacketStream& operator=(const McapPacketStream&) = delete;

  std::optional<lidar::mock::StreamPacket> next() override;
  bool rewind() override;
  [[nodiscard]] std::string error() const override;
  // The recorded LIDAR model and data port (from the first message; empty / 0 before it).
  [[nodiscard]] std::string model() const;

 private:
  struct Packet {
    Nanos time_ns = 0;
    bool position = false;
    std::vector<std::byte> bytes;
  };
  void start();
  void stop();
  void produce();

  std::string path_, topic_;
  std::unique_ptr<record::McapReader> reader_;
  std::thread thread_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Packet> queue_;     // under mu_
  std::size_t queued_bytes_ = 0;  // under mu_
  bool done_ = false, stop_ = false;  // under mu_
  std::string problems_;          // under mu_: the reader's problems and undecodable messages
  std::string model_;             // under mu_
  Packet current_;                // what next() returned last
};

// The opener `rig lidar replay --mcap` and mock {kind: mcap} use (lidar::mock::RecordingOpener).
inline std::unique_ptr<lidar::mock::PacketStream> open_lidar_recording(const std::string& path, const std::string& topic) {
  return std::make_unique<McapPacketStream>(path, topic);
}

}  // namespace sensor_rig::rig
