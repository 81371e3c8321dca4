// `rig lidar ...`: each tool lives in its own file and registers itself here.
#include <utility>

#include "lidar_commands.hpp"
#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::lidar {
void register_cli(CLI::App& app, cli::Context& ctx, mock::RecordingOpener open_recording) {
  auto* lidar = app.add_subcommand("lidar", "LIDAR tools: decode captures (drivers/lidar), replay them as a mock sensor");
  lidar->require_subcommand(1);
  register_replay_command(*lidar, ctx, std::move(open_recording));
}
}  // namespace sensor_rig::lidar
