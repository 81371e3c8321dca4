#pragma once
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar {
std::unique_ptr<ScanDecoder> make_velodyne_decoder(const DecoderOptions& options);
}  // namespace sensor_rig::lidar
