// `rig record` and `rig play` (SPEC §7): MCAP recordings of the rig's topics, and their replay.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "play.hpp"
#include "sensor_rig/common/cli.hpp"
#include "recorder.hpp"
#include "rig_commands.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/record/bag_metadata.hpp"
#include "sensor_rig/record/mcap_repair.hpp"
#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::rig {
namespace {

std::map<std::string, dds::Transport> transports() {
  return {{"udp", dds::Transport::kUdp}, {"shm", dds::Transport::kShm}};
}

// `rig record repair IN [--out OUT]` (record/mcap_repair.hpp): the intact part of a damaged MCAP file
// as a complete, indexed one. Without --out, IN is replaced and the original kept as IN.broken (a
// name neither `rig play` nor rosbag2 takes for a recording file). Prints the damage found on stderr
// and one JSON line on stdout. Returns 0 when all of IN up to its end (or a cut at its end: a killed
// writer) is in the output, 1 when a damaged place cut off data after it (the output holds what came
// before) or IN is not MCAP; bad usage throws UsageError (2).
int run_repair(const std::string& in, const std::string& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_regular_file(in, ec)) throw cli::UsageError(in + ": no such file");
  const bool in_place = out.empty();
  if (!in_place && fs::exists(out, ec) && fs::equivalent(in, out, ec))
    throw cli::UsageError("--out " + out + " is IN itself (leave --out away to replace IN, keeping IN.broken)");
  const std::string broken = in + ".broken";
  if (in_place && fs::exists(broken, ec))
    throw cli::UsageError(broken + " exists (a repair before?): give --out");
  const std::string target = in_place ? in + ".repairing" : out;

  record::RepairResult r;
  const Nanos t0 = monotonic_now_ns();
  try {
    r = record::repair_mcap(in, target);
  } catch (const record::McapError& e) {
    fs::remove(target, ec);
    std::fprintf(stderr, "rig record repair: %s\n", e.what());
    return cli::kRuntime;
  }
  const double seconds = static_cast<double>(monotonic_now_ns() - t0) / 1e9;
  if (in_place) {
    // The original first, so that a crash in between leaves both files, never neither.
    fs::rename(in, broken, ec);
    if (!ec) fs::rename(target, in, ec);
    if (ec) {
      std::fprintf(stderr, "rig record repair: cannot put the repaired file in place of %s: %s (it is %s)\n", in.c_str(),
                   ec.message().c_str(), target.c_str());
      return cli::kRuntime;
    }
  }
  const bool lost_after = !r.damage.empty() && !r.cut;
  bool failed = lost_after;
  if (!r.damage.empty())
    std::fprintf(stderr, "rig record repair: %s: %s; kept %llu messages in %llu chunks, the %llu bytes before offset %llu%s\n",
                 in.c_str(), r.damage.c_str(), static_cast<unsigned long long>(r.messages),
                 static_cast<unsigned long long>(r.chunks), static_cast<unsigned long long>(r.stopped_at),
                 static_cast<unsigned long long>(r.stopped_at),
                 lost_after ? "; what follows the damage is not recovered" : "");
  if (r.skipped_records > 0)
    std::fprintf(stderr, "rig record repair: %llu Attachment/Metadata record(s) not carried over\n",
                 static_cast<unsigned long long>(r.skipped_records));
  nlohmann::json j = {{"in", in},
                      {"out", in_place ? in : out},
                      {"input_bytes", r.input_bytes},
                      {"intact_bytes", r.stopped_at},
                      {"output_bytes", r.output_bytes},
                      {"messages", r.messages},
                      {"chunks", r.chunks},
                      {"schemas", r.schemas},
                      {"channels", r.channels},
                      {"had_summary", r.had_summary},
                      {"cut", r.cut},
                      {"damage", r.damage},
                      {"seconds", seconds},
                      {"mb_per_s", seconds > 0 ? static_cast<double>(r.stopped_at) / 1e6 / seconds : 0.0}};
  if (in_place) j["original"] = broken;
  // A file of a split recording (DIR/<DIR>_N.mcap): the folder's metadata.yaml names it now, with
  // its counts and times, and the totals include it (record/bag_metadata.hpp).
  const std::string placed = in_place ? in : out;
  if (record::split_file_index(placed) >= 0) {
    const std::string folder = fs::absolute(placed).parent_path().string();
    try {
      const auto refreshed = record::refresh_bag_metadata(folder);
      for (const auto& s : refreshed.skipped)
        std::fprintf(stderr, "rig record repair: %s/metadata.yaml: not listed: %s\n", folder.c_str(), s.c_str());
      j["metadata"] = (fs::path(folder) / "metadata.yaml").string();
      j["metadata_files"] = refreshed.listed;
    } catch (const record::McapError& e) {
      std::fprintf(stderr, "rig record repair: %s/metadata.yaml not updated: %s\n", folder.c_str(), e.what());
      j["metadata_error"] = e.what();
      failed = true;
    }
  }
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  return failed ? cli::kRuntime : cli::kOk;
}

void add_repair(CLI::App& record, cli::Context& ctx) {
  auto* cmd = record.add_subcommand(
      "repair", "Make a complete, indexed MCAP file of what is intact in a damaged one (a recorder killed before its summary)");
  auto in = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  cmd->add_option("IN", *in, "The damaged MCAP file")->required();
  cmd->add_option("--out", *out, "Where to write it (default: IN itself, the original kept as IN.broken)");
  cmd->callback([&ctx, in, out] { ctx.exit_code = run_repair(*in, *out); });
}

void add_record(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("record", "Record topics into MCAP (profile ros2, ros2msg schemas, CDR as received)");
  auto o = std::make_shared<RecordOptions>();
  auto domain = std::make_shared<int>(0);
  auto compression = std::make_shared<std::string>("zstd");
  cmd->add_option("TOPIC", o->topics, "ROS topic names (default: every topic discovered)");
  // Not ->required(): `rig record repair` has no --out of this command (checked in the callback).
  cmd->add_option("--out", o->out, "NAME.mcap, or a folder (created, must be empty) with --split-mb/--split-s");
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
  add_repair(*cmd, ctx);
  cmd->callback([&ctx, o, domain, compression, cmd] {
    if (cmd->got_subcommand("repair")) return;
    if (o->out.empty()) throw cli::UsageError("--out is required");
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
