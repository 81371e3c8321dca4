// libFuzzer harness for the Velodyne calibration parsers (VeloView XML, ROS YAML) and
// validate_for_model. Input: byte 0 picks the model (byte0 % 3: VLP-16, VLP-32C, HDL-32E) and the
// format (bit 6 set: ROS YAML, else VeloView XML); the rest is the file's text.
// Invariant: a calibration is either rejected (CalibrationError, the one error the parsers throw:
// yaml-cpp's and the XML reader's own errors must come out as it) or has one laser per model laser.
//
// Built with -DRIG_FUZZ_CORPUS_MAIN instead, this file is the corpus generator:
//   g++ -std=c++20 -DRIG_FUZZ_CORPUS_MAIN tests/fuzz/fuzz_velodyne_calibration.cpp
//   ./a.out tests/fuzz/corpus/velodyne_calibration
#include <cstddef>
#include <cstdint>
#include <string>

#ifndef RIG_FUZZ_CORPUS_MAIN
#include <cstdlib>

#include "sensor_rig/lidar/velodyne/calibration.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace velodyne = sensor_rig::lidar::velodyne;
  if (size < 1) return 0;
  const std::uint8_t mode = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  const auto model = static_cast<velodyne::Model>(mode % 3);
  try {
    const auto cal = (mode & 0x40) != 0 ? velodyne::parse_ros_yaml(text, "fuzz.yaml")
                                        : velodyne::parse_veloview_xml(text, "fuzz.xml");
    const auto valid = velodyne::validate_for_model(cal, model);
    if (valid.lasers.size() != static_cast<std::size_t>(velodyne::model_info(model).lasers)) std::abort();
  } catch (const velodyne::CalibrationError&) {
  }
  return 0;
}

#else  // corpus generator

#include <filesystem>
#include <fstream>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::filesystem::path dir(argv[1]);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "calibration_xml", std::ios::binary)
      << '\x80'  // VeloView XML, validated as a VLP-16
      << "<?xml version=\"1.0\"?>\n<boost_serialization>\n<DB>\n<distLSB_>0.2</distLSB_>\n<points_>\n"
         "<item><px><id_>0</id_><rotCorrection_>0</rotCorrection_><vertCorrection_>-15</vertCorrection_>"
         "<distCorrection_>1.5</distCorrection_></px></item>\n"
         "<item><px><id_>1</id_><vertCorrection_>1</vertCorrection_></px></item>\n</points_>\n</DB>\n"
         "</boost_serialization>\n";
  std::ofstream(dir / "calibration_yaml", std::ios::binary)
      << '\xC0'  // ROS YAML, validated as a VLP-16 (0xC0 % 3 == 0)
      << "lasers:\n- {laser_id: 0, rot_correction: 0.0, vert_correction: -0.2617993877991494,\n"
         "   dist_correction: 0.0, vert_offset_correction: 0.0112}\n"
         "- {laser_id: 1, vert_correction: 0.017453292519943295}\nnum_lasers: 2\ndistance_resolution: 0.002\n";
  return 0;
}

#endif
