#include "lidar_commands.hpp"

namespace sensor_rig::lidar {
void register_decode_command(CLI::App& /*lidar*/, cli::Context& /*ctx*/) {}
}  // namespace sensor_rig::lidar
