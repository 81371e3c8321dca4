#pragma once
// The `rig` command is one CLI11 app; each area adds its subcommands through a register function.
// A subcommand's callback stores its exit code in Context (SPEC §7: 0 ok, 1 runtime, 2 usage/config).
// Only files that build commands include this one; the others need only cli_context.hpp.
#include <CLI/CLI.hpp>

#include "sensor_rig/common/cli_context.hpp"
