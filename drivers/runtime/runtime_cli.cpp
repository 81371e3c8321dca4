#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::runtime {
void register_cli(CLI::App& app, cli::Context& /*ctx*/) {
  app.add_subcommand("config", "Configuration tools")->require_subcommand(1);
}
}  // namespace sensor_rig::runtime
