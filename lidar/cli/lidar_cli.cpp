#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::lidar {
void register_cli(CLI::App& app, cli::Context& /*ctx*/) {
  auto* lidar = app.add_subcommand("lidar", "LIDAR tools: decode captures, replay them as a mock sensor");
  lidar->require_subcommand(1);
}
}  // namespace sensor_rig::lidar
