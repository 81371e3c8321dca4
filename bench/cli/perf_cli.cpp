// `rig perf ...`: the paper's evaluation (SPEC §9). run, table1, table2, report, ddsperf, and the
// internal `node` subcommand the runner starts once per load-generator process.
#include <cstdio>

#include "sensor_rig/bench/perf/analysis.hpp"
#include "sensor_rig/bench/perf/ddsperf.hpp"
#include "sensor_rig/bench/perf/grid.hpp"
#include "sensor_rig/bench/perf/node.hpp"
#include "sensor_rig/bench/perf/report.hpp"
#include "sensor_rig/bench/perf/runner.hpp"
#include "sensor_rig/common/cli.hpp"

namespace sensor_rig::bench {
namespace {
namespace perf = sensor_rig::bench::perf;

struct RunArgs {
  std::string size = "0B", transport = "udp", message = "fixed", reader = "copy", profile;
  perf::RunSpec spec;
  double fault_kill = -1;
};

void add_node(CLI::App& perf_app, cli::Context& ctx) {
  auto* sub = perf_app.add_subcommand("node", "internal: one load-generator process (started by `rig perf run`)");
  sub->group("");  // hidden
  auto a = std::make_shared<perf::NodeArgs>();
  auto role = std::make_shared<std::string>();
  auto msg = std::make_shared<std::string>("fixed");
  auto reader = std::make_shared<std::string>("copy");
  auto topics = std::make_shared<std::vector<int>>();
  sub->add_option("--role", *role)->required()->check(CLI::IsMember({"pub", "sub"}));
  sub->add_option("--index", a->index)->required();
  sub->add_option("--topics", *topics)->required()->delimiter(',');
  sub->add_option("--matches", a->expected_matches)->required();
  sub->add_option("--run-id", a->run_id)->required();
  sub->add_option("--domain", a->domain)->required();
  sub->add_option("--profile", a->profile)->required();
  sub->add_option("--size", a->size)->required();
  sub->add_option("--message", *msg);
  sub->add_option("--reader", *reader);
  sub->add_option("--rate", a->rate_hz)->required();
  sub->add_option("--count", a->count)->required();
  sub->add_option("--depth", a->depth);
  sub->add_option("--rt-priority", a->rt_priority);
  sub->add_option("--csv", a->csv)->required();
  sub->add_option("--stats", a->stats);
  sub->add_flag("!--no-loan", a->loan, "copy instead of loaning samples");
  sub->callback([a, role, msg, reader, topics, &ctx] {
    a->role = *role == "pub" ? perf::Role::kPublisher : perf::Role::kSubscriber;
    a->message = perf::parse_message(*msg);
    a->reader = perf::parse_reader_mode(*reader);
    a->topics = *topics;
    ctx.exit_code = perf::run_node(*a);
  });
}

void add_run(CLI::App& perf_app, cli::Context& ctx) {
  auto* sub = perf_app.add_subcommand("run", "one configuration: start the nodes, measure, write DIR/summary.json");
  auto r = std::make_shared<RunArgs>();
  sub->add_option("--topology", r->spec.topology, "1: N/2 pub->sub pairs, 2: 1 pub -> N-1 subs, 3: N-1 pubs -> 1 sub node")
      ->required();
  sub->add_option("--nodes", r->spec.nodes, "processes")->required();
  sub->add_option("--size", r->size, "0B 16B 64kB 512kB 1MB 2MB (also Struct16 Array64k PointCloud1m)")->required();
  sub->add_option("--rate", r->spec.rate_hz, "publish rate, Hz")->required();
  sub->add_option("--duration", r->spec.duration_s, "seconds of publishing")->required();
  sub->add_option("--transport", r->transport, "udp | udp-tuned | shm")->capture_default_str();
  sub->add_option("--message", r->message,
                  "fixed (fixed-size struct per size, loanable) | seq (header + sequence<octet>) | "
                  "pointcloud2 (sensor_msgs/PointCloud2 as the LIDAR driver publishes it)")
      ->capture_default_str();
  sub->add_option("--reader", r->reader,
                  "pointcloud2 subscribers: copy (deserialize, as a ROS 2 node) | view (read the serialized "
                  "sample in place, in the iceoryx chunk over shm)")
      ->capture_default_str();
  sub->add_option("--depth", r->spec.depth, "keep-last depth")->capture_default_str();
  sub->add_option("--domain", r->spec.domain, "DDS domain id (default: from the runner's pid)");
  sub->add_option("--rt-priority", r->spec.rt_priority, "nodes run SCHED_FIFO at this priority (0: normal scheduling)");
  sub->add_option("--profile", r->profile, "Cyclone XML instead of config/cyclonedds/perf-<transport>.xml");
  sub->add_option("--fault-kill-subscriber", r->fault_kill, "fault injection: SIGKILL the last subscriber at t0 + S");
  sub->add_option("--out", r->spec.out, "output directory")->required();
  sub->callback([r, &ctx] {
    r->spec.size = perf::parse_size(r->size);
    r->spec.transport = perf::parse_transport(r->transport);
    r->spec.message = perf::parse_message(r->message);
    r->spec.reader = perf::parse_reader_mode(r->reader);
    perf::RunOptions opt;
    opt.profile = r->profile;
    opt.fault_kill_subscriber_s = r->fault_kill;
    const auto s = perf::run(r->spec, opt);
    std::printf("%s\n", perf::summary_line(s).c_str());
    ctx.exit_code = s["failed_nodes"].empty() && s.value("completed", false) ? cli::kOk : cli::kRuntime;
  });
}

void add_table(CLI::App& perf_app, cli::Context& ctx, int which) {
  const std::string name = "table" + std::to_string(which);
  auto* sub = perf_app.add_subcommand(name, which == 1 ? "the paper's Table 1 grid: 2/32 nodes x Struct16/Array64k/PointCloud1m, 10 Hz"
                                                       : "the paper's Table 2 grid: 2/8/32/64 nodes x 0B..2MB x 10/100 Hz");
  auto g = std::make_shared<perf::GridOptions>();
  g->table = which;
  auto transport = std::make_shared<std::string>("shm");
  auto message = std::make_shared<std::string>("fixed");
  sub->add_option("--duration", g->duration_s, "seconds per run (paper: 60)")->capture_default_str();
  sub->add_option("--message", *message, "fixed | seq | pointcloud2")->capture_default_str();
  sub->add_option("--transport", *transport, "udp | udp-tuned | shm")->capture_default_str();
  sub->add_option("--out", g->out, "output directory (one subdirectory per run)")->required();
  sub->add_option("--topology", g->topologies, "only these topologies (default 1 2 3)")->delimiter(',');
  sub->add_option("--nodes", g->nodes, "only these node counts")->delimiter(',');
  sub->add_option("--size", g->sizes, "only these sizes")->delimiter(',');
  sub->add_option("--rate", g->rates, "only these rates (Hz)")->delimiter(',');
  sub->add_option("--domain", g->domain, "DDS domain id");
  sub->add_option("--rt-priority", g->rt_priority, "nodes run SCHED_FIFO at this priority (0: normal scheduling)");
  sub->add_flag("--no-report", g->no_report, "skip writing report.html");
  sub->callback([g, transport, message, &ctx] {
    g->transport = perf::parse_transport(*transport);
    g->message = perf::parse_message(*message);
    ctx.exit_code = perf::run_grid(*g);
  });
}

void add_report(CLI::App& perf_app, cli::Context& ctx) {
  auto* sub = perf_app.add_subcommand("report", "write DIR/report.html (plots) and DIR/report.md (table vs the paper)");
  auto dir = std::make_shared<std::string>();
  sub->add_option("DIR", *dir, "a run directory or a table directory")->required();
  sub->callback([dir, &ctx] {
    const auto r = perf::write_report(*dir);
    std::printf("%s\n%s\n", r.html.c_str(), r.markdown.c_str());
    ctx.exit_code = r.runs > 0 ? cli::kOk : cli::kRuntime;
  });
}

void add_ddsperf(CLI::App& perf_app, cli::Context& ctx) {
  auto* sub = perf_app.add_subcommand("ddsperf", "Cyclone's ddsperf ping/pong on the same sizes and profiles: the floor");
  auto o = std::make_shared<perf::DdsperfOptions>();
  auto transport = std::make_shared<std::string>("udp-tuned");
  auto sizes = std::make_shared<std::vector<std::string>>();
  sub->add_option("--transport", *transport, "udp | udp-tuned | shm")->capture_default_str();
  sub->add_option("--size", *sizes, "sizes (default all)")->delimiter(',');
  sub->add_option("--rate", o->rate_hz, "ping rate, Hz")->capture_default_str();
  sub->add_option("--duration", o->duration_s, "seconds per size")->capture_default_str();
  sub->add_option("--domain", o->domain, "DDS domain id");
  sub->add_option("--out", o->out, "output directory (ddsperf.json)")->required();
  sub->callback([o, transport, sizes, &ctx] {
    o->transport = perf::parse_transport(*transport);
    for (const auto& s : *sizes) o->sizes.push_back(perf::parse_size(s));
    ctx.exit_code = perf::run_ddsperf(*o);
  });
}

}  // namespace

void register_cli(CLI::App& app, cli::Context& ctx) {
  auto* perf_app = app.add_subcommand("perf",
                                      "The DDS latency/loss evaluation of Kouril et al., \"Performance Evaluation of "
                                      "a ROS2 Based Automated Driving System\" (docs/perf.md)");
  perf_app->require_subcommand(1);
  add_run(*perf_app, ctx);
  add_table(*perf_app, ctx, 1);
  add_table(*perf_app, ctx, 2);
  add_report(*perf_app, ctx);
  add_ddsperf(*perf_app, ctx);
  add_node(*perf_app, ctx);
}

}  // namespace sensor_rig::bench
