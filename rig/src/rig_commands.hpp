#pragma once
// Every area's register function; the list is the whole `rig` command tree.
#include "sensor_rig/common/cli_context.hpp"
#include "can_recording_log.hpp"
#include "lidar_recording_stream.hpp"

namespace sensor_rig {
namespace lidar { void register_cli(CLI::App& app, cli::Context& ctx, mock::RecordingOpener open_recording); }
namespace dbw { void register_cli(CLI::App& app, cli::Context& ctx); }
namespace bench { void register_cli(CLI::App& app, cli::Context& ctx); }
namespace rig {
void register_cli(CLI::App& app, cli::Context& ctx);
void register_security_cli(CLI::App& app, cli::Context& ctx);  // security init
void register_chaos_cli(CLI::App& app, cli::Context& ctx);     // chaos
void register_view_cli(CLI::App& app, cli::Context& ctx);      // view (Foxglove WebSocket server)
void register_record_cli(CLI::App& app, cli::Context& ctx);    // record, play (MCAP)
}  // namespace rig
namespace drivers {
void register_lidar_cli(CLI::App& app, cli::Context& ctx);
void register_dbw_cli(CLI::App& app, cli::Context& ctx);
}  // namespace drivers

inline void register_all_commands(CLI::App& app, cli::Context& ctx) {
  rig::register_cli(app, ctx);  // up, demo, config, monitor
  rig::register_security_cli(app, ctx);
  rig::register_chaos_cli(app, ctx);
  rig::register_view_cli(app, ctx);
  rig::register_record_cli(app, ctx);
#ifdef RIG_HAVE_LIDAR
  lidar::register_cli(app, ctx, rig::open_lidar_recording);  // lidar replay (--mcap read by record/)
  drivers::register_lidar_cli(app, ctx);  // lidar decode (source -> timesync -> decoder -> PCD)
#endif
#ifdef RIG_HAVE_DBW
  dbw::can::register_frame_log_kind("mcap", rig::open_can_recording);  // CAN transport mcap:FILE[@RATE] (read by record/)
  dbw::register_cli(app, ctx);      // can ..., mock paravan
  drivers::register_dbw_cli(app, ctx);  // dbw bridge|send (the DDS node)
#endif
#ifdef RIG_HAVE_BENCH
  bench::register_cli(app, ctx);    // perf ...
#endif
}
}  // namespace sensor_rig
