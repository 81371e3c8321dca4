#pragma once
// `rig lidar replay --mcap FILE --mcap-topic TOPIC`: a LIDAR's raw channel recorded by `rig record
// --raw` (sensor_rig_msgs/msg/LidarPackets, docs/recording.md "Raw channels") as a packet stream,
// each datagram at its recorded kernel receive time, the second port's (dst_port != the recorded
// data_port) marked as position packets. A split recording's folder (`--mcap drive/`) is one stream:
// its files in metadata.yaml's order (recording_files(), as the CAN replay reads them). A reader
// thread decompresses and decodes up to 32 MiB ahead, so the paced sender only pops. A damaged file
// (cut, corrupt chunk, undecodable message) plays what is intact; error() then names each place by
// its byte offset (in a folder, after its file's path).
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "mcap_channel_pump.hpp"
#include "sensor_rig/lidar/mock/replay.hpp"

namespace sensor_rig::rig {

class McapPacketStream final : public lidar::mock::PacketStream {
 public:
  // `path`: a file, or a split recording's folder. Throws std::runtime_error when the (first) file
  // is not MCAP or has no LidarPackets channel `topic` (the message names the LidarPackets channels
  // it has), or the folder holds no recording.
  McapPacketStream(const std::string& path, const std::string& topic);

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
  std::string decode(const dds::LidarPacketsView& view, const std::function<bool(Packet&&)>& push);

  mutable std::mutex model_mu_;
  std::string model_;  // under model_mu_
  Packet current_;     // what next() returned last
  McapChannelPump<dds::LidarPacketsView, Packet> pump_;  // last: its thread stops before the above go
};

// The opener `rig lidar replay --mcap` and mock {kind: mcap} use (lidar::mock::RecordingOpener).
inline std::unique_ptr<lidar::mock::PacketStream> open_lidar_recording(const std::string& path, const std::string& topic) {
  return std::make_unique<McapPacketStream>(path, topic);
}

}  // namespace sensor_rig::rig
