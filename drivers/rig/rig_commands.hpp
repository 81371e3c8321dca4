#pragma once
// Every area's register function; the list is the whole `rig` command tree.
#include "sensor_rig/common/cli.hpp"

namespace sensor_rig {
namespace lidar { void register_cli(CLI::App& app, cli::Context& ctx); }
namespace dbw { void register_cli(CLI::App& app, cli::Context& ctx); }
namespace bench { void register_cli(CLI::App& app, cli::Context& ctx); }
namespace runtime { void register_cli(CLI::App& app, cli::Context& ctx); }

inline void register_all_commands(CLI::App& app, cli::Context& ctx) {
  runtime::register_cli(app, ctx);  // up, demo, config, monitor
  lidar::register_cli(app, ctx);    // lidar decode|replay|...
  dbw::register_cli(app, ctx);      // can ..., dbw ..., mock paravan
  bench::register_cli(app, ctx);    // perf ...
}
}  // namespace sensor_rig
