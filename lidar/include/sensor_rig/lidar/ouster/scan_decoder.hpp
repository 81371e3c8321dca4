#pragma once
// The Ouster decoder behind the vendor-neutral ScanDecoder interface (models OS-LEGACY and OS).
#include <memory>

#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar {

// OS-LEGACY: the metadata must name the LEGACY profile (or none); OS: any other profile.
// Throws DecoderConfigError naming the metadata key at fault.
std::unique_ptr<ScanDecoder> make_ouster_decoder(const DecoderOptions& options);

}  // namespace sensor_rig::lidar
