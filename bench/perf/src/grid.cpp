#include "sensor_rig/bench/perf/grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "sensor_rig/bench/perf/analysis.hpp"
#include "sensor_rig/bench/perf/report.hpp"
#include "sensor_rig/bench/perf/roudi.hpp"
#include "sensor_rig/bench/perf/runner.hpp"
#include "sensor_rig/common/cli_context.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/shutdown.hpp"

namespace sensor_rig::bench::perf {
namespace fs = std::filesystem;

std::vector<RunSpec> grid_specs(const GridOptions& g) {
  std::vector<int> nodes = g.table == 1 ? std::vector<int>{2, 32} : std::vector<int>{2, 8, 32, 64};
  std::vector<std::uint32_t> sizes = g.table == 1 ? std::vector<std::uint32_t>{16, 65536, 1048576}
                                                  : std::vector<std::uint32_t>{0, 65536, 524288, 1048576, 2097152};
  std::vector<double> rates = g.table == 1 ? std::vector<double>{10} : std::vector<double>{10, 100};
  std::vector<int> topologies = g.topologies.empty() ? std::vector<int>{1, 2, 3} : g.topologies;
  for (int t : topologies) {
    if (t < 1 || t > 3) throw cli::UsageError("--topology must be 1, 2 or 3");
  }
  if (!g.nodes.empty()) {
    std::erase_if(nodes, [&](int n) { return std::find(g.nodes.begin(), g.nodes.end(), n) == g.nodes.end(); });
  }
  if (!g.sizes.empty()) {
    std::vector<std::uint32_t> want;
    for (const auto& s : g.sizes) want.push_back(parse_size(s));
    std::erase_if(sizes, [&](std::uint32_t s) { return std::find(want.begin(), want.end(), s) == want.end(); });
  }
  if (!g.rates.empty()) {
    std::erase_if(rates, [&](double r) { return std::find(g.rates.begin(), g.rates.end(), r) == g.rates.end(); });
  }
  std::vector<RunSpec> specs;
  for (double rate : rates) {
    for (std::uint32_t size : sizes) {
      for (int n : nodes) {
        for (int t : topologies) {
          if (n == 2 && t != topologies.front()) continue;  // one pub, one sub: the same run
          RunSpec s;
          s.topology = t;
          s.nodes = n;
          s.size = size;
          s.rate_hz = rate;
          s.duration_s = g.duration_s;
          s.transport = g.transport;
          s.message = g.message;
          s.domain = g.domain;
          s.rt_priority = g.rt_priority;
          // Appended, not `"_" + name`: GCC 12 at -O3 reports a false -Wrestrict on that operator+.
          std::string message_suffix;
          if (g.message != Message::kFixed) message_suffix.append("_").append(to_string(g.message));
          char dir[128];
          std::snprintf(dir, sizeof dir, "T%d_N%d_%s_%gHz_%s%s", t, n, size_label(size).c_str(), rate,
                        to_string(g.transport).c_str(), message_suffix.c_str());
          s.out = (fs::path(g.out) / dir).string();
          specs.push_back(s);
        }
      }
    }
  }
  return specs;
}

int run_grid(const GridOptions& g) {
  if (g.out.empty()) throw cli::UsageError("--out DIR is required");
  if (!(g.duration_s > 0)) throw cli::UsageError("--duration must be > 0");
  const auto specs = grid_specs(g);
  if (specs.empty()) throw cli::UsageError("the filters leave no configuration to run");
  fs::create_directories(g.out);
  std::unique_ptr<RouDi> roudi;
  if (g.transport == Transport::kShm) {
    std::fprintf(stderr, "[perf] starting iox-roudi for the grid (%s)\n", default_roudi_config().c_str());
    roudi = std::make_unique<RouDi>(default_roudi_config(), (fs::path(g.out) / "roudi.log").string());
  }
  int failures = 0;
  const Nanos start = monotonic_now_ns();
  for (std::size_t i = 0; i < specs.size() && !shutdown_requested(); ++i) {
    double eta = 0;
    if (i > 0) {
      const double per = static_cast<double>(monotonic_now_ns() - start) / 1e9 / static_cast<double>(i);
      eta = per * static_cast<double>(specs.size() - i);
    } else {
      eta = static_cast<double>(specs.size()) * (g.duration_s + 8.0);
    }
    std::fprintf(stderr, "[perf] table %d: run %zu/%zu %s, ETA %.0f min %.0f s\n", g.table, i + 1, specs.size(),
                 specs[i].label().c_str(), std::floor(eta / 60), std::fmod(eta, 60.0));
    RunOptions opt;
    opt.roudi = roudi.get();
    try {
      const auto s = run(specs[i], opt);
      std::printf("%s\n", summary_line(s).c_str());
      std::fflush(stdout);
      if (!s["failed_nodes"].empty() || !s.value("completed", false)) ++failures;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "[perf] %s failed: %s\n", specs[i].label().c_str(), e.what());
      ++failures;
    }
  }
  roudi.reset();
  if (!g.no_report) {
    const auto r = write_report(g.out);
    std::printf("%s\n%s\n", r.html.c_str(), r.markdown.c_str());
  }
  return failures == 0 && !shutdown_requested() ? 0 : 1;
}

}  // namespace sensor_rig::bench::perf
