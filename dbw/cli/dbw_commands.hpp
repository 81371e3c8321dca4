#pragma once
// The dbw area's `rig` subcommands, one register function per command group.
#include "sensor_rig/common/cli_context.hpp"

namespace sensor_rig::dbw {
void register_can_cli(CLI::App& can, cli::Context& ctx);
void register_mock_cli(CLI::App& mock, cli::Context& ctx);
}  // namespace sensor_rig::dbw
