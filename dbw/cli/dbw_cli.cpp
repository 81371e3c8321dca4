#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::dbw {
void register_cli(CLI::App& app, cli::Context& /*ctx*/) {
  app.add_subcommand("can", "CAN tools: decode candump logs with DBC files")->require_subcommand(1);
  app.add_subcommand("dbw", "Drive-by-wire tools: command source, bridge")->require_subcommand(1);
  app.add_subcommand("mock", "Mock devices: the Paravan ECU")->require_subcommand(1);
}
}  // namespace sensor_rig::dbw
