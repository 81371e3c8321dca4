// `rig record` and `rig play` (SPEC §7): MCAP recordings of the rig's topics, and their replay.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "play.hpp"
#include "recorder.hpp"
#include "rig_commands.hpp"
#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::rig {
namespace {

std::map<std::string, dds::Transport> transports() {
  return {{"udp", dds::Transport::kUdp}, {"shm", dds::Transport::kShm}};
}

void add_record(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("record", "Record topics into MCAP (profile ros2, ros2msg schemas, CDR as received)");
  auto o = std::make_shared<RecordOptions>();
  auto domain = std::make_shared<int>(0);
  auto compression = std::make_shared<std::string>("zstd");
  cmd->add_option("TOPIC", o->topics, "ROS topic names (default: every topic discovered)");
  cmd->add_option("--out", o->out, "NAME.mcap, or a folder (created, must be empty) with --split-mb/--split-s")->required();
  cmd->add_option("--duration", o->duration_s, "Stop after S seconds (default: at SIGINT/SIGTERM)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--domain", *domain, "DDS domain id")->check(CLI::Range(0, 232));
  cmd->add_option("--dds-profile", o->dds.profile, "Cyclone XML profile (default: loopback)");
  cmd->add_option("--transport", o->dds.transport, "udp, or shm: iceoryx shared memory (a RouDi must run, as `rig up` starts)")
      ->transform(CLI::CheckedTransformer(transports()));
  cmd->add_option("--compression", *compression, "Chunk compression")->check(CLI::IsMember({"none", "lz4", "zstd"}))->capture_default_str();
  auto* mb = cmd->add_option("--split-mb", o->split_mb, "A new file every N MiB")->check(CLI::PositiveNumber);
  auto* s = cmd->add_option("--split-s", o->split_s, "A new file every S seconds of log time")->check(CLI::PositiveNumber);
  mb->excludes(s);
  cmd->add_option("--chunk-kb", o->chunk_kb, "Uncompressed KiB per chunk (what a killed recorder can lose)")
      ->check(CLI::Range(16, 65536))->capture_default_str();
  cmd->add_option("--queue-mb", o->queue_mb, "MiB queued for the writer thread at most (then samples are dropped, counted)")
      ->check(CLI::Range(1, 16384))->capture_default_str();
  cmd->add_flag("--raw", o->raw,
                "Also the raw channels (beside every topic, or beside the TOPICs named): each LIDAR's packets "
                "(/sensors/lidar/NAME/packets) and the CAN frames (/vehicle/can/frames), which the drivers publish only while recorded");
  cmd->add_flag("!--no-progress", o->progress, "No progress line on stderr");
  cmd->add_option("--rt-priority", o->rt_priority, "SCHED_FIFO priority of the recorder's threads and its DDS threads (0: normal)")
      ->check(CLI::Range(0, 99));
  cmd->callback([&ctx, o, domain, compression] {
    namespace fs = std::filesystem;
    std::error_code ec;
    const bool split = o->split_mb > 0 || o->split_s > 0;
    if (split && fs::exists(o->out, ec) && !(fs::is_directory(o->out, ec) && fs::is_empty(o->out, ec)))
      throw cli::UsageError(o->out + " exists and is not an empty folder (a split recording is a folder of its own)");
    if (!split && fs::is_directory(o->out, ec))
      throw cli::UsageError(o->out + " is a folder: give a file NAME.mcap (or split with --split-mb / --split-s)");
    o->dds.domain_id = static_cast<dds_domainid_t>(*domain);
    o->compression = *record::parse_compression(*compression);
    try {
      ctx.exit_code = run_record(*o);
    } catch (const record::McapError& e) {
      std::fprintf(stderr, "rig record: %s\n", e.what());
      ctx.exit_code = cli::kRuntime;
    }
  });
}

}  // namespace

void register_record_cli(CLI::App& app, cli::Context& ctx) {
  add_record(app, ctx);
  add_play(app, ctx);
}

}  // namespace sensor_rig::rig
