#pragma once
// Per-laser corrections in the model used by the ROS velodyne driver and VeloView: metres and
// radians, rotation correction subtracted from the azimuth, offsets in the sensor frame.
// Parsing takes text (no file I/O); errors throw CalibrationError naming source:line and the field.
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/lidar/velodyne/model.hpp"

namespace sensor_rig::lidar::velodyne {

struct CalibrationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct LaserCorrection {
  int laser_id = 0;
  double rot_correction = 0.0;           // rad, subtracted from the azimuth
  double vert_correction = 0.0;          // rad, elevation
  double dist_correction = 0.0;          // m, added to the distance
  double dist_correction_x = 0.0;        // m (HDL-64 two-point correction; must be 0 here)
  double dist_correction_y = 0.0;        // m
  double vert_offset_correction = 0.0;   // m
  double horiz_offset_correction = 0.0;  // m
  double focal_distance = 0.0;           // HDL-64 intensity correction, ignored
  double focal_slope = 0.0;
};

struct Calibration {
  std::vector<LaserCorrection> lasers;  // indexed by laser_id after validation
  // Metres per distance count; 0 = the file does not say (validation takes the model's value).
  double distance_resolution_m = 0.0;
  // Lasers the file says it describes (ROS `num_lasers`); 0 = not stated (VeloView XML, built in).
  int num_lasers = 0;
  std::string source;                   // file name or "built-in <model>", for messages
};

// Manual values for the model (vertical angles, azimuth offsets, VLP-16 vertical offsets).
Calibration default_calibration(Model m);
// ROS velodyne_pointcloud YAML (lasers: [...], num_lasers, distance_resolution).
Calibration parse_ros_yaml(const std::string& text, const std::string& source);
// VeloView XML (boost serialization DB: distLSB_ in cm, points_ with px entries, degrees/cm).
Calibration parse_veloview_xml(std::string_view text, const std::string& source);
// Chooses the parser from the content (an XML prolog or <boost_serialization> means VeloView).
Calibration parse_calibration(const std::string& text, const std::string& source);
// Checks the calibration fits the model and returns it trimmed to the model's lasers, ordered by
// laser_id. Throws CalibrationError for a calibration of another model: a stated laser count other
// than the model's, a used laser id beyond the model's lasers, a distance resolution other than the
// model's (VLP-16, HDL-32E 2 mm; VLP-32C 4 mm) — and for missing/duplicate ids, non-finite or
// implausible values, unsupported fields.
Calibration validate_for_model(Calibration c, Model m);

}  // namespace sensor_rig::lidar::velodyne
