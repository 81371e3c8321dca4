#pragma once
// `rig play`: a recording's topics published again under their names, types (dds/type_registry.hpp,
// by schema name; a schema in the file that differs from the rig's is refused, as is an unknown
// type) and QoS (the channel's offered_qos_profiles, else reliable keep-last 10), each message
// written when its log-time offset from the first one (divided by --rate) has passed on
// CLOCK_MONOTONIC. Bad places in the file are reported with their offsets and what is intact plays.
#include <string>
#include <vector>

#include "sensor_rig/common/cli_context.hpp"
#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::rig {

struct PlayOptions {
  std::string path;            // NAME.mcap, or a folder of split files (played in order)
  double rate = 1.0;
  bool loop = false;
  double start_s = 0;          // skip the first S seconds of the recording
  std::vector<std::string> topics;  // ROS names; empty: all
  double delay_s = 1.0;        // after creating the writers, before the first message (discovery)
  int rt_priority = 0;         // > 0: the timed writing thread SCHED_FIFO
  dds::DomainConfig dds;
};

// Plays; the summary (JSON, one line) on stdout. 0, or 1 when the file had bad places (played up to
// and around them) or nothing in it could be played.
int run_play(const PlayOptions& options);
void add_play(CLI::App& app, cli::Context& ctx);

}  // namespace sensor_rig::rig
