#include "sensor_rig/lidar/decoder_files.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace sensor_rig::lidar {
namespace {

std::string read_file(const std::string& path, const char* what) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw DecoderFileError(std::string(what) + " file not found: " + path);
  if (std::filesystem::is_directory(path, ec))
    throw DecoderFileError(std::string(what) + " " + path + " is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DecoderFileError(std::string("cannot read ") + what + " file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

DecoderFiles read_decoder_files(const std::string& calibration, const std::string& metadata) {
  DecoderFiles f;
  if (!calibration.empty()) {
    f.calibration_text = read_file(calibration, "calibration");
    f.calibration_name = calibration;
  }
  if (!metadata.empty()) {
    f.metadata_text = read_file(metadata, "metadata");
    if (f.metadata_text.find_first_not_of(" \t\r\n") == std::string::npos)
      throw DecoderFileError("metadata file " + metadata + " is empty");
    f.metadata_name = metadata;
  }
  return f;
}

}  // namespace sensor_rig::lidar
