#pragma once
// The `rig` command is one CLI11 app; each area adds its subcommands through a register function.
// A subcommand's callback stores its exit code in Context (SPEC §7: 0 ok, 1 runtime, 2 usage/config).
#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

namespace sensor_rig::cli {

struct Context {
  int exit_code = 0;
};

enum Exit : int { kOk = 0, kRuntime = 1, kUsage = 2 };

// Thrown for bad arguments or configuration detected after parsing; main maps it to exit 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace sensor_rig::cli
