#pragma once
// The calibration and metadata files a config or a command names, read once into text for the
// decoders and the synthetic sensors (which parse text, no I/O). One reader for the LIDAR node,
// `rig config check`, `rig lidar decode` and `rig lidar replay`.
#include <stdexcept>
#include <string>

namespace sensor_rig::lidar {

// A file that cannot be used: missing, a directory, unreadable, or (metadata) empty.
struct DecoderFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct DecoderFiles {
  std::string calibration_text, calibration_name;  // empty = the model's built-in values
  std::string metadata_text, metadata_name;        // Ouster sensor metadata JSON
};

// Empty paths are skipped. Throws DecoderFileError naming the file and why.
DecoderFiles read_decoder_files(const std::string& calibration, const std::string& metadata);

// Copies the texts into any options struct with the four fields (DecoderOptions, SyntheticOptions).
template <class Options>
void apply_decoder_files(const DecoderFiles& f, Options& o) {
  o.calibration_text = f.calibration_text;
  o.calibration_name = f.calibration_name;
  o.metadata_text = f.metadata_text;
  o.metadata_name = f.metadata_name;
}

}  // namespace sensor_rig::lidar
