#include "sensor_rig/bench/perf/runner.hpp"

#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <thread>

#include "sensor_rig/bench/perf/analysis.hpp"
#include "sensor_rig/bench/perf/node.hpp"
#include "sensor_rig/bench/perf/roudi.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/cli_context.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/shutdown.hpp"

#ifndef RIG_PERF_SOURCE_DIR
#define RIG_PERF_SOURCE_DIR "."
#endif

namespace sensor_rig::bench::perf {
namespace fs = std::filesystem;
namespace {

#define PERF_PROGRESS(on, ...)          \
  do {                                   \
    if (on) {                            \
      std::fprintf(stderr, "[perf] ");   \
      std::fprintf(stderr, __VA_ARGS__); \
      std::fputc('\n', stderr);          \
    }                                    \
  } while (false)

std::vector<std::string> node_argv(const std::string& exe, const RunSpec& spec, const NodePlan& n,
                                   const std::string& run_id, int domain, const std::string& profile,
                                   const std::string& csv, const std::string& stats) {
  std::string topics;
  for (int t : n.topics) topics += (topics.empty() ? "" : ",") + std::to_string(t);
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.9g", spec.rate_hz);
  return {exe, "perf", "node", "--role", n.role == Role::kPublisher ? "pub" : "sub", "--index", std::to_string(n.index),
          "--topics", topics, "--matches", std::to_string(n.expected_matches), "--run-id", run_id,
          "--domain", std::to_string(domain), "--profile", profile, "--size", std::to_string(spec.size),
          "--message", to_string(spec.message), "--reader", to_string(spec.reader), "--rate", rate, "--count", std::to_string(spec.count()),
          "--depth", std::to_string(spec.depth), "--rt-priority", std::to_string(spec.rt_priority), "--csv", csv,
          "--stats", stats};
}

// Stops children politely (STOP / SIGTERM), then by force; only the ones given, only while running.
void stop_children(const std::vector<ChildProcess*>& kids, int grace_ms) {
  for (ChildProcess* c : kids) {
    c->send_line("STOP");
    c->close_stdin();
  }
  const Nanos end = monotonic_now_ns() + static_cast<Nanos>(grace_ms) * 1'000'000;
  for (ChildProcess* c : kids) {
    const auto left = static_cast<int>(std::max<Nanos>(0, end - monotonic_now_ns()) / 1'000'000);
    c->wait_exit(left);
  }
}

}  // namespace

std::string source_dir() {
  if (const char* s = std::getenv("RIG_SOURCE_DIR"); s != nullptr && *s != '\0') return s;
  return RIG_PERF_SOURCE_DIR;
}
std::string default_profile(Transport t) {
  return (fs::path(source_dir()) / "config/cyclonedds" / ("perf-" + to_string(t) + ".xml")).string();
}
std::string default_roudi_config() { return (fs::path(source_dir()) / "config/iceoryx/perf-roudi.toml").string(); }

nlohmann::json run(const RunSpec& spec, const RunOptions& opt) {
  spec.validate();
  const std::string profile = opt.profile.empty() ? default_profile(spec.transport) : opt.profile;
  if (!fs::exists(profile)) throw cli::UsageError("Cyclone profile '" + profile + "' not found");
  fs::create_directories(spec.out);
  const fs::path out = fs::absolute(spec.out);
  for (const auto& e : fs::directory_iterator(out)) {  // a rerun into the same directory starts clean
    const auto name = e.path().filename().string();
    const bool node_stats = name.rfind("node_", 0) == 0 && e.path().extension() == ".json";
    if (name.rfind("pub_", 0) == 0 || name.rfind("sub_", 0) == 0 || name == "summary.json" || node_stats) fs::remove(e.path());
  }
  fs::copy_file(profile, out / "profile.xml", fs::copy_options::overwrite_existing);
  static int run_counter = 0;
  const std::string run_id = std::to_string(::getpid()) + "x" + std::to_string(run_counter++);
  const int domain = spec.domain >= 0 ? spec.domain : 100 + ::getpid() % 100;
  const auto plan = plan_nodes(spec);
  int subscriptions = 0;
  for (const auto& n : plan) subscriptions += n.role == Role::kSubscriber ? static_cast<int>(n.topics.size()) : 0;

  RunInput input;
  input.spec = spec;
  input.domain = domain;
  input.extra["profile"] = profile;
  input.extra["run_id"] = run_id;
  input.extra["label"] = spec.label();

  // Shared memory: a RouDi for this run unless the caller (a table) holds one.
  std::unique_ptr<RouDi> own_roudi;
  pid_t roudi_pid = 0;
  ProcessUsage roudi_before;  // to charge the run with what RouDi used during it (tables share one)
  if (spec.transport == Transport::kShm) {
    if (opt.roudi == nullptr) {
      const auto cfg = out / "roudi.toml";
      std::ofstream(cfg) << roudi_config(spec.size, roudi_chunks_for(publisher_count(spec), subscriptions));
      PERF_PROGRESS(opt.progress, "starting iox-roudi (%s)", cfg.c_str());
      own_roudi = std::make_unique<RouDi>(cfg.string(), (out / "roudi.log").string());
      if (own_roudi->external()) input.warnings.push_back("used an already running RouDi (pid " + std::to_string(own_roudi->pid()) + ")");
    }
    const RouDi* r = opt.roudi != nullptr ? opt.roudi : own_roudi.get();
    input.extra["roudi"] = {{"pid", r->pid()}, {"external", r->external()}, {"owned_by_run", own_roudi != nullptr && !r->external()},
                            {"startup_s", r->startup_s()}};
    roudi_pid = r->pid();
    roudi_before = process_usage(roudi_pid);
  }

  // Exec through /proc/self/exe (resolved in the child, a copy of us): the very binary that runs
  // this runner, even if it was replaced on disk by a rebuild since.
  const std::string exe = "/proc/self/exe";
  input.extra["rig"] = self_executable();
  std::vector<std::unique_ptr<ChildProcess>> kids;
  pid_t pgid = 0;
  for (const auto& n : plan) {
    const std::string csv = (out / ((n.role == Role::kPublisher ? "pub_" : "sub_") + std::to_string(n.index) + ".csv")).string();
    const std::string err = (out / ("node_" + std::to_string(n.index) + ".log")).string();
    const std::string stats = (out / ("node_" + std::to_string(n.index) + ".json")).string();
    fs::remove(err);
    ChildOptions co;
    co.log_file = err;
    co.pipe_stdio = true;
    co.process_group = pgid;  // the nodes share a group of their own: Ctrl-C reaches the runner only
    kids.push_back(std::make_unique<ChildProcess>(node_argv(exe, spec, n, run_id, domain, profile, csv, stats), co));
    if (pgid == 0) pgid = kids.front()->pid();
    NodeOutcome o;
    o.plan = n;
    o.pid = kids.back()->pid();
    o.csv = csv;
    o.stats = stats;
    input.nodes.push_back(o);
  }
  const int n_nodes = static_cast<int>(kids.size());

  // Discovery barrier: every node reports READY when all its endpoints matched.
  const int disc_timeout_s = opt.discovery_timeout_s > 0 ? opt.discovery_timeout_s : 20 + n_nodes / 2;
  std::vector<bool> ready(kids.size(), false);
  int n_ready = 0;
  bool failed_start = false;
  const Nanos disc_start = monotonic_now_ns();
  Nanos next_tick = disc_start + 1'000'000'000;
  while (n_ready < n_nodes && !failed_start && !shutdown_requested()) {
    std::vector<pollfd> fds;
    fds.reserve(kids.size());
    for (const auto& k : kids) fds.push_back({k->stdout_fd(), POLLIN, 0});
    ::poll(fds.data(), fds.size(), 100);
    for (std::size_t i = 0; i < kids.size(); ++i) {
      for (const auto& line : kids[i]->read_lines()) {
        if (line == "READY" && !ready[i]) {
          ready[i] = true;
          ++n_ready;
        }
      }
      if (!ready[i] && (kids[i]->stdout_eof() || !kids[i]->running())) {
        input.warnings.push_back("node " + std::to_string(i) + " ended before discovery completed (see node_" + std::to_string(i) + ".log)");
        failed_start = true;
      }
    }
    const Nanos now = monotonic_now_ns();
    if (now >= next_tick) {
      PERF_PROGRESS(opt.progress, "%s: discovery %d/%d nodes matched (%.0f s)", spec.label().c_str(), n_ready, n_nodes,
               static_cast<double>(now - disc_start) / 1e9);
      next_tick += 1'000'000'000;
    }
    if (now - disc_start > static_cast<Nanos>(disc_timeout_s) * 1'000'000'000) {
      input.warnings.push_back("discovery did not complete within " + std::to_string(disc_timeout_s) + " s (" +
                               std::to_string(n_ready) + "/" + std::to_string(n_nodes) + " nodes ready)");
      failed_start = true;
    }
  }
  input.extra["discovery_s"] = static_cast<double>(monotonic_now_ns() - disc_start) / 1e9;

  bool aborted = failed_start || shutdown_requested();
  if (!aborted) {
    // Common start time, far enough ahead that every node has read it.
    const Nanos t0 = vehicle_now_ns() + 200'000'000 + static_cast<Nanos>(n_nodes) * 5'000'000;
    input.t0_ns = t0;
    for (auto& k : kids) k->send_line("START " + std::to_string(t0));
    const Nanos run_ns = static_cast<Nanos>(std::llround(1e9 * spec.count() / spec.rate_hz));
    const Nanos pub_deadline = t0 + run_ns + 15'000'000'000;  // pacing + ack wait + margin
    bool fault_done = opt.fault_kill_subscriber_s < 0;
    Nanos next = vehicle_now_ns() + 1'000'000'000;
    for (;;) {
      int pubs_alive = 0, alive = 0;
      for (std::size_t i = 0; i < kids.size(); ++i) {
        if (kids[i]->running()) {
          ++alive;
          if (plan[i].role == Role::kPublisher) ++pubs_alive;
        }
      }
      const Nanos now = vehicle_now_ns();
      if (!fault_done && now >= t0 + static_cast<Nanos>(opt.fault_kill_subscriber_s * 1e9)) {
        fault_done = true;
        ChildProcess& victim = *kids.back();  // the last node is always a subscriber
        PERF_PROGRESS(opt.progress, "fault injection: SIGKILL subscriber node %d (pid %d)", n_nodes - 1, victim.pid());
        victim.signal(SIGKILL);
        input.extra["fault_injection"] = {{"killed_node", n_nodes - 1}, {"at_s", opt.fault_kill_subscriber_s}};
      }
      if (pubs_alive == 0 || now > pub_deadline || shutdown_requested()) break;
      if (now >= next) {
        const double el = static_cast<double>(now - t0) / 1e9;
        PERF_PROGRESS(opt.progress, "%s: %5.1f/%.1f s  nodes alive %d/%d", spec.label().c_str(), std::max(0.0, el),
                 static_cast<double>(run_ns) / 1e9, alive, n_nodes);
        next += 1'000'000'000;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    aborted = shutdown_requested();
  }

  // Stop: subscribers drain on STOP; anything still running after the grace period is terminated.
  std::vector<ChildProcess*> all;
  all.reserve(kids.size());
  for (auto& k : kids) all.push_back(k.get());
  stop_children(all, 5000);
  for (std::size_t i = 0; i < kids.size(); ++i) {
    if (kids[i]->running()) {
      input.nodes[i].stopped_by_runner = true;
      kids[i]->signal(SIGTERM);
    }
  }
  for (auto& k : kids) {
    if (!k->wait_exit(2000)) {
      k->signal(SIGKILL);
      k->wait_exit(2000);
    }
  }
  for (std::size_t i = 0; i < kids.size(); ++i) {
    const auto& e = kids[i]->exit_info();
    auto& o = input.nodes[i];
    o.exited = e.exited;
    o.exit_code = e.exit_code;
    o.term_signal = e.term_signal;
    o.cpu_s = e.cpu_s;
    o.max_rss_kb = e.max_rss_kb;
  }
  kids.clear();
  if (roudi_pid > 0) {
    // RouDi's CPU and RSS: during the run from /proc (works for a table's shared RouDi too), and for
    // a RouDi this run started, its whole life from wait4 (startup touches every mempool chunk).
    auto& j = input.extra["roudi"];
    const ProcessUsage after = process_usage(roudi_pid);
    if (after.known && roudi_before.known) {
      j["cpu_s"] = after.cpu_s - roudi_before.cpu_s;
      j["max_rss_kb"] = after.max_rss_kb;
    } else {
      input.warnings.push_back("RouDi (pid " + std::to_string(roudi_pid) + "): CPU and RSS not readable from /proc");
    }
    if (own_roudi && !own_roudi->external()) {
      own_roudi->stop();
      j["lifetime_cpu_s"] = own_roudi->stopped_cpu_s();
      j["lifetime_max_rss_kb"] = own_roudi->stopped_max_rss_kb();
    }
  }
  own_roudi.reset();
  if (failed_start) input.warnings.push_back("run did not start: no message was published");
  if (aborted && !failed_start) input.warnings.push_back("run interrupted");
  input.extra["completed"] = !aborted;

  auto summary = analyse(input);
  std::ofstream(out / "summary.json") << summary.dump(2) << "\n";
  return summary;
}

}  // namespace sensor_rig::bench::perf
