#pragma once
#include "sensor_rig/common/cli_context.hpp"
#include "sensor_rig/lidar/mock/replay.hpp"

namespace sensor_rig::lidar {
// `open_recording` serves --mcap (empty: refused with the reason).
void register_replay_command(CLI::App& lidar, cli::Context& ctx, mock::RecordingOpener open_recording);  // replay_command.cpp
}  // namespace sensor_rig::lidar
