#pragma once
// The CAN transport `mcap:FILE[@RATE]` (dbw/can registers the kind, the `rig` executable gives it
// this reader: dbw/ sits below record/): the raw CAN channel of a `rig record --raw` file
// (sensor_rig_msgs/msg/CanFrame on /vehicle/can/frames, docs/recording.md "Raw channels") as the
// frames a bridge receives, each at its recorded kernel receive time and stamped with it, so a drive
// recorded on the car replays through `rig dbw bridge --transport mcap:drive.mcap` on the desk. A
// split recording's folder (`mcap:drive/`) is one stream: its files in metadata.yaml's order.
// A reader thread decompresses and decodes up to 64 Ki frames ahead. A damaged file (cut, corrupt
// chunk, undecodable message) replays what is intact; error() names each place by its byte offset.
#include <cstdint>
#include <memory>
#include <string>

#include "mcap_channel_pump.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::rig {

inline constexpr const char* kCanFramesTopic = "/vehicle/can/frames";

class McapCanLog final : public dbw::can::FrameLog {
 public:
  // The CanFrame channel /vehicle/can/frames, or the file's only CanFrame channel (of a folder: the
  // first file's that has one, then that topic in the others). Throws std::runtime_error when the
  // file is not MCAP or no file has such a channel (naming those the first has).
  explicit McapCanLog(const std::string& path);

  bool next(dbw::can::LoggedFrame& out) override;
  [[nodiscard]] std::uint64_t malformed() const override;
  [[nodiscard]] std::string error() const override;
  // 1 s, as `rig play --delay` and a LIDAR's mock {kind: mcap}: the bridge's readers match first.
  [[nodiscard]] Nanos default_delay_ns() const override { return 1'000'000'000; }
  [[nodiscard]] const std::string& topic() const noexcept { return pump_.topic(); }

 private:
  McapChannelPump<dds::CanFrameView, dbw::can::LoggedFrame> pump_;
};

// The opener registered as the CAN transport kind `mcap` (dbw::can::register_frame_log_kind).
std::unique_ptr<dbw::can::FrameLog> open_can_recording(const std::string& path);

}  // namespace sensor_rig::rig
