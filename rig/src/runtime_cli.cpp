// `rig up`, `rig demo`, `rig config check`, `rig monitor`, `rig report`.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <map>

#include "latency_plot.hpp"
#include "monitor.hpp"
#include "rig_config.hpp"
#include "rig_runner.hpp"
#include "rig_shm.hpp"
#include "sample_record.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "sensor_rig/dds/roudi.hpp"
#include "sensor_rig/dds/security.hpp"

#ifndef RIG_DEFAULT_SOURCE_DIR
#define RIG_DEFAULT_SOURCE_DIR "."
#endif

namespace sensor_rig::rig {
namespace {

std::string default_mock_config() {
  const char* src = std::getenv("RIG_SOURCE_DIR");
  return (std::filesystem::path(src != nullptr ? src : RIG_DEFAULT_SOURCE_DIR) / "config/mock_rig.yaml").string();
}

void add_up(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("up", "Run the drivers (and mock devices) a config names");
  auto config = std::make_shared<std::string>();
  auto duration = std::make_shared<double>(0);
  cmd->add_option("CONFIG", *config, "Rig config (YAML)")->required();
  cmd->add_option("--duration", *duration, "Stop after S seconds (0 = until Ctrl-C)")->check(CLI::NonNegativeNumber);
  auto supervised = std::make_shared<bool>(false);
  cmd->add_flag("--roudi-supervised", *supervised)->group("");  // internal: the parent `rig up` runs RouDi
  cmd->callback([&ctx, config, duration, supervised] {
    const auto cfg = load_rig_config(*config);
    if (cfg.dds.transport == dds::Transport::kShm && !*supervised) {
      ctx.exit_code = run_shm_supervisor(cfg, *config, *duration);
      return;
    }
    ctx.exit_code = run_rig(cfg, RunOptions{*duration});
  });
}

// The monitor's thread under SCHED_FIFO, before its participant: the threads that starts inherit the
// policy (iceoryx's listener over shm cannot be named in Cyclone's <Threads>).
void monitor_thread_realtime(int priority) {
  if (priority <= 0) return;
  if (const auto r = try_realtime_priority(priority); !r)
    log::warn("monitor", "SCHED_FIFO " + std::to_string(priority) + " refused (" + r.why_not +
                             "), running with normal priority");
}

// Over shared memory the monitor runs as a process of its own: stopping RouDi SIGTERMs every
// process registered with it, and this one must outlive `rig up` to report its exit.
int run_demo_monitor_process(const RigConfig& cfg, ChildProcess& rig, const MonitorOptions& mo) {
  for (int i = 0; i < 600 && rig.running() && !dds::probe_roudi().answers; ++i) ::usleep(100'000);
  std::vector<std::string> argv{self_executable(), "monitor", "--domain", std::to_string(cfg.dds.domain_id),
                                "--transport", "shm", "--duration", std::to_string(mo.duration_s)};
  if (!cfg.dds.profile.empty()) argv.insert(argv.end(), {"--dds-profile", cfg.dds.profile});
  if (mo.json) argv.emplace_back("--json");
  if (cfg.dds.realtime_priority > 0) argv.insert(argv.end(), {"--rt-priority", std::to_string(cfg.dds.realtime_priority)});
  for (const auto& [flag, file] : {std::pair{"--record", mo.record_file}, std::pair{"--plot", mo.plot_file},
                                   std::pair{"--summary", mo.summary_file}})
    if (!file.empty()) argv.insert(argv.end(), {flag, file});
  ChildProcess monitor(argv);
  while (monitor.running() && rig.running() && !shutdown_requested()) wait_for_shutdown(100);
  const int monitor_status = monitor.stop(5000);
  if (!rig.running() && !shutdown_requested()) {
    std::fprintf(stderr, "rig demo: `rig up` exited with status %d (see its messages above)\n", rig.exit_status());
    return cli::kRuntime;
  }
  rig.stop(20000);
  return monitor_status;
}

void add_demo(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("demo", "The whole rig on mock devices with a live status table");
  auto config = std::make_shared<std::string>(default_mock_config());
  auto mo = std::make_shared<MonitorOptions>();
  cmd->add_option("--config", *config, "Rig config (default config/mock_rig.yaml)");
  cmd->add_option("--duration", mo->duration_s, "Stop after S seconds (0 = until Ctrl-C)")->check(CLI::NonNegativeNumber);
  cmd->add_flag("--json", mo->json, "Monitor output as JSON lines");
  cmd->add_option("--record", mo->record_file, "Write one CSV row per sample: its stage times (as `rig monitor --record`)");
  cmd->add_option("--plot", mo->plot_file, "At the end, write the latency plot of the run (SVG)");
  cmd->add_option("--summary", mo->summary_file, "At the end, write whole-run percentiles per topic/stage (JSON)");
  cmd->callback([&ctx, config, mo] {
    const auto cfg = load_rig_config(*config);  // validate before starting anything
    std::fprintf(stderr, "%s", describe(cfg).c_str());
    // Real processes: mocks and drivers in `rig up`, the monitor here.
    ChildProcess rig({self_executable(), "up", *config});
    if (cfg.dds.transport == dds::Transport::kShm) {
      ctx.exit_code = run_demo_monitor_process(cfg, rig, *mo);
      return;
    }
    mo->dds = cfg.dds;
    mo->realtime_priority = cfg.dds.realtime_priority;
    monitor_thread_realtime(mo->realtime_priority);
    mo->keep_going = [&rig] { return rig.running(); };
    ctx.exit_code = run_monitor(*mo);
    mo->keep_going = nullptr;  // it refers to this call's `rig`
    if (!rig.running() && !shutdown_requested()) {
      std::fprintf(stderr, "rig demo: `rig up %s` exited with status %d (see its messages above)\n", config->c_str(),
                   rig.exit_status());
      ctx.exit_code = cli::kRuntime;
      return;
    }
    rig.stop(5000);
  });
}

void add_config(CLI::App& app, cli::Context& ctx) {
  auto* cfg = app.add_subcommand("config", "Configuration tools");
  cfg->require_subcommand(1);
  auto* check = cfg->add_subcommand("check", "Validate a rig config; errors name file:line:key (exit 2)");
  auto path = std::make_shared<std::string>();
  check->add_option("CONFIG", *path, "Rig config (YAML)")->required();
  check->callback([&ctx, path] {
    const auto c = load_rig_config(*path);  // throws ConfigError -> exit 2
    std::printf("%s: ok\n%s", path->c_str(), describe(c).c_str());
    ctx.exit_code = 0;
  });
}

void add_monitor(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("monitor", "Live per-topic rate, size, latency stages and loss");
  auto opt = std::make_shared<MonitorOptions>();
  auto profile = std::make_shared<std::string>();
  auto domain = std::make_shared<int>(0);
  cmd->add_option("TOPIC", opt->topics, "ROS topic names (default: all known)");
  cmd->add_option("--duration", opt->duration_s, "Stop after S seconds")->check(CLI::NonNegativeNumber);
  cmd->add_flag("--json", opt->json, "One JSON line per topic per second");
  cmd->add_option("--domain", *domain, "DDS domain id")->check(CLI::Range(0, 232));
  cmd->add_option("--dds-profile", *profile, "Cyclone XML profile (default: loopback)");
  auto transport = std::make_shared<dds::Transport>(dds::Transport::kUdp);
  cmd->add_option("--transport", *transport, "udp, or shm: iceoryx shared memory (a RouDi must run, as `rig up` starts)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, dds::Transport>{{"udp", dds::Transport::kUdp},
                                                                                {"shm", dds::Transport::kShm}}));
  cmd->add_option("--rt-priority", opt->realtime_priority,
                  "SCHED_FIFO priority for the monitor and its DDS threads (0: normal scheduling)")
      ->check(CLI::Range(0, 99));
  cmd->add_option("--summary", opt->summary_file, "At the end, write whole-run percentiles per topic/stage (JSON)");
  cmd->add_option("--record", opt->record_file, "Write one CSV row per sample: its stage times, missing packets");
  cmd->add_option("--plot", opt->plot_file, "At the end, write the latency plot of the run (SVG)");
  cmd->add_option("--loss-timeout", opt->loss_timeout_s, "A stamped sample not received after S seconds is lost")
      ->check(CLI::PositiveNumber);
  auto security_dir = std::make_shared<std::string>();
  auto identity = std::make_shared<std::string>("reader");
  cmd->add_option("--security", *security_dir,
                  "DDS Security: a `rig security init` directory, to read the protected /vehicle/dbw/cmd");
  cmd->add_option("--identity", *identity, "DDS Security identity in that directory")->capture_default_str();
  // Hidden: `copy` reads clouds and images as before the views (dds/README.md), for side-by-side runs.
  auto reader = std::make_shared<std::string>("view");
  cmd->add_option("--reader", *reader)->check(CLI::IsMember({"view", "copy"}))->group("");
  cmd->callback([&ctx, opt, profile, domain, transport, security_dir, identity, reader] {
    opt->copy_clouds = *reader == "copy";
    if (!security_dir->empty()) {
      try {
        opt->security = dds::security_files(*security_dir, *identity);
      } catch (const std::runtime_error& e) {
        throw cli::UsageError(e.what());
      }
    }
    opt->dds.domain_id = static_cast<dds_domainid_t>(*domain);
    opt->dds.profile = *profile;
    opt->dds.transport = *transport;
    opt->dds.realtime_priority = opt->realtime_priority;
    monitor_thread_realtime(opt->realtime_priority);
    ctx.exit_code = run_monitor(*opt);
  });
}

void add_report(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("report", "Plots of a `rig monitor --record` recording");
  auto record = std::make_shared<std::string>();
  auto plot = std::make_shared<std::string>();
  cmd->add_option("RECORD", *record, "CSV written by `rig monitor --record`")->required()->check(CLI::ExistingFile);
  cmd->add_option("--plot", *plot, "SVG: per topic, latency per stage over time (lost marked) and box plots")
      ->required();
  cmd->callback([&ctx, record, plot] {
    std::vector<SampleRecord> rows;
    try {
      rows = read_records(*record);
    } catch (const std::runtime_error& e) {
      throw cli::UsageError(e.what());  // not a recording: bad input, exit 2
    }
    write_latency_plot(*plot, rows);
    std::fprintf(stderr, "%s: %zu samples -> %s\n", record->c_str(), rows.size(), plot->c_str());
    ctx.exit_code = 0;
  });
}

}  // namespace

void register_cli(CLI::App& app, cli::Context& ctx) {
  add_up(app, ctx);
  add_demo(app, ctx);
  add_config(app, ctx);
  add_monitor(app, ctx);
  add_report(app, ctx);
}

}  // namespace sensor_rig::rig
