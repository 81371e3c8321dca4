#include "sensor_rig/bench/perf/ddsperf.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/bench/perf/roudi.hpp"
#include "sensor_rig/bench/perf/runner.hpp"
#include "sensor_rig/common/cli_context.hpp"
#include "sensor_rig/common/shutdown.hpp"

namespace sensor_rig::bench::perf {
namespace fs = std::filesystem;
namespace {
constexpr const char* kDdsperf = "/usr/bin/ddsperf";

double parse_us(const std::string& tok) {
  double v = std::stod(tok);
  if (tok.find("ms") != std::string::npos) v *= 1000.0;
  else if (tok.find("ns") != std::string::npos) v /= 1000.0;
  else if (tok.find("us") == std::string::npos && tok.find('s') != std::string::npos) v *= 1e6;
  return v;
}
}  // namespace

bool parse_ddsperf_line(const std::string& line, DdsperfInterval& out) {
  std::istringstream in(line);
  std::vector<std::string> tok;
  for (std::string t; in >> t;) tok.push_back(t);
  DdsperfInterval d;
  int seen = 0;
  try {
    for (std::size_t i = 0; i + 1 < tok.size(); ++i) {
      const std::string& k = tok[i];
      const std::string& v = tok[i + 1];
      if (k == "size") d.size = static_cast<std::uint32_t>(std::stoul(v)), ++seen;
      else if (k == "mean") d.mean_us = parse_us(v), ++seen;
      else if (k == "min") d.min_us = parse_us(v), ++seen;
      else if (k == "50%") d.p50_us = parse_us(v), ++seen;
      else if (k == "90%") d.p90_us = parse_us(v), ++seen;
      else if (k == "99%") d.p99_us = parse_us(v), ++seen;
      else if (k == "max") d.max_us = parse_us(v), ++seen;
      else if (k == "cnt") d.cnt = std::stoull(v), ++seen;
    }
  } catch (const std::exception&) {
    return false;
  }
  if (seen < 8) return false;
  out = d;
  return true;
}

nlohmann::json aggregate_ddsperf(const std::vector<DdsperfInterval>& v) {
  double n = 0, mean = 0, p50 = 0, p90 = 0, p99 = 0, mx = 0, mn = 1e300;
  for (const auto& d : v) {
    const auto c = static_cast<double>(d.cnt);
    n += c;
    mean += d.mean_us * c;
    p50 += d.p50_us * c;
    p90 += d.p90_us * c;
    p99 += d.p99_us * c;
    mx = std::max(mx, d.max_us);
    mn = std::min(mn, d.min_us);
  }
  if (n == 0) return {{"roundtrips", 0}};
  auto ms = [](double us) { return us / 1000.0; };
  return {{"roundtrips", static_cast<std::uint64_t>(n)},
          {"rtt_ms", {{"mean", ms(mean / n)}, {"min", ms(mn)}, {"p50", ms(p50 / n)}, {"p90", ms(p90 / n)}, {"p99", ms(p99 / n)}, {"max", ms(mx)}}},
          {"one_way_ms_est", {{"mean", ms(mean / n / 2)}, {"p50", ms(p50 / n / 2)}, {"p99", ms(p99 / n / 2)}, {"max", ms(mx / 2)}}}};
}

std::vector<std::string> unmeasured_sizes(const nlohmann::json& result) {
  std::vector<std::string> v;
  for (const auto& s : result.value("sizes", nlohmann::json::array())) {
    if (s.value("roundtrips", std::uint64_t{0}) == 0) v.push_back(s.value("size_label", std::string("?")));
  }
  return v;
}

int run_ddsperf(const DdsperfOptions& o) {
  if (o.out.empty()) throw cli::UsageError("--out DIR is required");
  if (::access(kDdsperf, X_OK) != 0) throw std::runtime_error("ddsperf not found (Debian package cyclonedds-tools)");
  std::vector<std::uint32_t> sizes = o.sizes;
  if (sizes.empty()) sizes = {0, 16, 65536, 524288, 1048576, 2097152};
  fs::create_directories(o.out);
  const std::string profile = default_profile(o.transport);
  ::setenv("CYCLONEDDS_URI", ("file://" + profile).c_str(), 1);
  const int domain = o.domain >= 0 ? o.domain : 100 + ::getpid() % 100;
  std::unique_ptr<RouDi> roudi;
  if (o.transport == Transport::kShm) roudi = std::make_unique<RouDi>(default_roudi_config(), (fs::path(o.out) / "roudi.log").string());
  nlohmann::json result = {{"transport", to_string(o.transport)}, {"profile", profile}, {"rate_hz", o.rate_hz},
                           {"duration_s", o.duration_s}, {"tool", "ddsperf (Cyclone DDS 0.10.2), topic KS, ping/pong"},
                           {"sizes", nlohmann::json::array()}};
  const std::string dur = std::to_string(static_cast<int>(std::max(1.0, o.duration_s)));
  char rate[32];
  std::snprintf(rate, sizeof rate, "%gHz", o.rate_hz);
  for (std::uint32_t size : sizes) {
    if (shutdown_requested()) break;
    // ddsperf's KS payload includes 12 bytes of its own; "size 0" means that minimum.
    const std::uint32_t s = size < 12 ? 0 : size;
    const auto pong_log = (fs::path(o.out) / ("pong_" + size_label(size) + ".log")).string();
    const auto ping_log = (fs::path(o.out) / ("ping_" + size_label(size) + ".log")).string();
    fs::remove(pong_log);
    fs::remove(ping_log);
    ChildOptions pong_opt, ping_opt;
    pong_opt.log_file = pong_log;
    pong_opt.process_group = 0;
    ping_opt.log_file = ping_log;
    ping_opt.process_group = 0;
    ChildProcess pong({kDdsperf, "-D", std::to_string(std::stoi(dur) + 5), "-i", std::to_string(domain), "pong"}, pong_opt);
    ChildProcess ping({kDdsperf, "-D", dur, "-i", std::to_string(domain), "ping", rate, "size", std::to_string(s)}, ping_opt);
    std::fprintf(stderr, "[perf] ddsperf %s %s %s for %s s\n", to_string(o.transport).c_str(), size_label(size).c_str(), rate, dur.c_str());
    if (!ping.wait_exit(static_cast<int>(o.duration_s * 1000) + 20000)) ping.signal(SIGTERM);
    ping.wait_exit(2000);
    pong.signal(SIGTERM);
    if (!pong.wait_exit(3000)) pong.signal(SIGKILL);
    std::vector<DdsperfInterval> v;
    std::ifstream in(ping_log);
    for (std::string line; std::getline(in, line);) {
      DdsperfInterval d;
      if (parse_ddsperf_line(line, d)) v.push_back(d);
    }
    auto j = aggregate_ddsperf(v);
    j["size"] = size;
    j["size_label"] = size_label(size);
    j["ddsperf_size_arg"] = s;
    result["sizes"].push_back(j);
    if (j.contains("one_way_ms_est")) {
      std::printf("ddsperf %s %s: rtt mean %.3f ms p99 %.3f ms -> one-way ~%.3f ms (%llu round trips)\n",
                  to_string(o.transport).c_str(), size_label(size).c_str(), j["rtt_ms"]["mean"].get<double>(),
                  j["rtt_ms"]["p99"].get<double>(), j["one_way_ms_est"]["mean"].get<double>(),
                  j["roundtrips"].get<unsigned long long>());
    } else {
      std::printf("ddsperf %s %s: no round trips (see %s)\n", to_string(o.transport).c_str(), size_label(size).c_str(), ping_log.c_str());
    }
  }
  // Sizes without a single round trip: the floor is unknown there, and the command says so.
  const auto unmeasured = unmeasured_sizes(result);
  result["unmeasured"] = unmeasured;
  std::ofstream(fs::path(o.out) / "ddsperf.json") << result.dump(2) << "\n";
  if (shutdown_requested()) return 1;
  if (!unmeasured.empty()) {
    std::string list;
    for (const auto& u : unmeasured) list += (list.empty() ? "" : ", ") + u;
    std::fprintf(stderr, "rig perf ddsperf: no round trip measured for %s; see ping_<size>.log / pong_<size>.log in %s\n",
                 list.c_str(), o.out.c_str());
    return 1;
  }
  return 0;
}

}  // namespace sensor_rig::bench::perf
