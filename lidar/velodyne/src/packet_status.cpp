#include "sensor_rig/lidar/packet.hpp"

namespace sensor_rig::lidar {

const char* to_string(PacketStatus s) noexcept {
  switch (s) {
    case PacketStatus::kOk: return "ok";
    case PacketStatus::kWrongSize: return "wrong_size";
    case PacketStatus::kBadBlockFlag: return "bad_block_flag";
    case PacketStatus::kWrongModel: return "wrong_model";
    case PacketStatus::kBadAzimuth: return "bad_azimuth";
    case PacketStatus::kNotData: return "not_data";
    case PacketStatus::kTimeBackwards: return "time_backwards";
    case PacketStatus::kOutOfOrder: return "out_of_order";
    case PacketStatus::kBadTime: return "bad_time";
  }
  return "unknown";
}

}  // namespace sensor_rig::lidar
