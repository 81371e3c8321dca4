#pragma once
#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::lidar {
void register_replay_command(CLI::App& lidar, cli::Context& ctx);  // replay_command.cpp
}  // namespace sensor_rig::lidar
