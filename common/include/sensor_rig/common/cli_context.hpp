#pragma once
// What command code shares without CLI11 itself: the exit codes, the usage error and a declaration
// of CLI::App for the register functions' signatures. Including <CLI/CLI.hpp> costs a file ~9 s of
// CPU at -O2 even when it uses nothing of it (CLI11 2.1 defines its validators as objects in the
// header: grid.cpp 13.5 s with it, 4.8 s without), so only the files that build commands include
// sensor_rig/common/cli.hpp.
#include <stdexcept>

namespace CLI {
class App;
}

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
