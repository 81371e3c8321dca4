#include "dbw_commands.hpp"
#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::dbw {
void register_cli(CLI::App& app, cli::Context& ctx) {
  register_can_cli(*app.add_subcommand("can", "CAN tools: decode and replay candump logs")->require_subcommand(1), ctx);
  register_mock_cli(*app.add_subcommand("mock", "Mock devices: the Paravan ECU")->require_subcommand(1), ctx);
}
}  // namespace sensor_rig::dbw
