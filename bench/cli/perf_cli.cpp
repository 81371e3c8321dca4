#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::bench {
void register_cli(CLI::App& app, cli::Context& /*ctx*/) {
  app.add_subcommand("perf", "The DDS latency/loss evaluation of Kouril et al.")->require_subcommand(1);
}
}  // namespace sensor_rig::bench
