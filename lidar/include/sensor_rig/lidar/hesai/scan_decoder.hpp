#pragma once
// The Hesai decoder behind the vendor-neutral ScanDecoder interface (registry rows Pandar40P,
// PandarXT32). DecoderOptions::calibration_text is an angle-correction CSV, or a Firetime CSV
// (recognised by its header), which replaces the built-in firing times.
#include <memory>

#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar {
std::unique_ptr<ScanDecoder> make_hesai_decoder(const DecoderOptions& options);
}  // namespace sensor_rig::lidar
