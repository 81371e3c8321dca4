#pragma once
// Hesai angle correction (per channel elevation and azimuth offset, degrees) and firing times.
// Parsing takes text (no file I/O); errors throw DecoderConfigError naming source:line and why.
//
// Angle CSV (HesaiLidar SDK / nebula):   Laser id,Elevation,Azimuth      (header; "Channel" too)
//                                         1,14.794,-1.042                 (channel 1-based, degrees)
// Firetime CSV (HesaiLidar SDK):          Channel,fire time(us)
//                                         1,6                             (µs, in any row order)
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::hesai {

struct ChannelAngles {
  double elevation_deg = 0.0;  // up positive
  double azimuth_deg = 0.0;    // added to the block azimuth (clockwise seen from above)
};

struct Calibration {
  std::vector<ChannelAngles> channels;  // index = channel - 1
  std::string source;                   // file name or "built-in <model>"
};

struct FiringTimes {
  std::vector<double> us;  // index = channel - 1; meaning as ModelInfo::firing_us
  std::string source;
};

// The user manual's nominal angles (Pandar40P: 15° .. -25° with -1.042/3.125/-5.208° azimuth
// offsets; PandarXT32: 15° .. -16° in 1° steps, no azimuth offset).
Calibration default_calibration(Model m);
FiringTimes default_firing_times(Model m);

Calibration parse_angle_csv(std::string_view text, const std::string& source, Model m);
FiringTimes parse_firetime_csv(std::string_view text, const std::string& source, Model m);
// True when the text's header names a firing-time table ("Channel,fire time...").
bool is_firetime_csv(std::string_view text) noexcept;

}  // namespace sensor_rig::lidar::hesai
