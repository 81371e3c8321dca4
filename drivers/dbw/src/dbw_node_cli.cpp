// `rig dbw send ...` (SPEC §7) and `rig dbw bridge [--config YAML] [--transport SPEC] [--duration S]`.
#include <cstdio>
#include <memory>
#include <string>

#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/dds/security.hpp"
#include "sensor_rig/drivers/dbw/dds_bridge.hpp"

namespace sensor_rig::drivers {
namespace {

using namespace sensor_rig::dbw;  // NOLINT(google-build-using-namespace): the node speaks dbw's types

struct BridgeOptions {
  std::string config;
  std::string transport = std::string("unix:") + kDefaultBusSocket;
  double duration = 0.0;
  bool json = false;
  int domain = -1;
  std::string security_dir;
  std::string identity = "dbw_bridge";
};

int run_bridge(const BridgeOptions& o) {
  const Protocol protocol = Protocol::load(o.config.empty() ? default_protocol_config() : o.config);
  std::unique_ptr<can::Transport> bus;
  try {
    bus = can::open_transport(o.transport);
  } catch (const can::TransportError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return cli::kRuntime;
  }
  std::fprintf(stderr, "dbw bridge: %s, protocol %s (hash %s)\n", bus->name().c_str(), protocol.mapping_path().c_str(),
               protocol.config_hash().c_str());
  DdsBridgeOptions bo;
  bo.duration_s = o.duration;
  bo.domain = o.domain;
  bo.security_dir = o.security_dir;
  bo.identity = o.identity;
  const auto s = run_dds_bridge(protocol, *bus, bo);
  std::printf("{\"commands\":%llu,\"frames_sent\":%llu,\"latency_us\":{\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f},"
              "\"take_to_send_us\":{\"p50\":%.1f,\"p99\":%.1f},\"silence_to_neutral_ms\":%.3f,"
              "\"status_published\":%llu,\"state_published\":%llu,\"commands_deferred\":%llu,"
              "\"neutral_sets_on_stop\":%llu,\"config_hash\":\"%s\"}\n",
              static_cast<unsigned long long>(s.commands), static_cast<unsigned long long>(s.frames_sent),
              s.latency_p50_us, s.latency_p99_us, s.latency_max_us, s.take_to_send_p50_us, s.take_to_send_p99_us,
              s.silence_to_neutral_ms, static_cast<unsigned long long>(s.status_published),
              static_cast<unsigned long long>(s.state_published), static_cast<unsigned long long>(s.commands_deferred),
              static_cast<unsigned long long>(s.neutral_sets_on_stop), protocol.config_hash().c_str());
  std::fflush(stdout);
  if (s.transport_closed) {
    std::fprintf(stderr, "error: CAN transport %s closed\n", bus->name().c_str());
    return cli::kRuntime;
  }
  return cli::kOk;
}

// DDS Security (issue 13): the participant authenticates as IDENTITY of a `rig security init` DIR.
void add_security_options(CLI::App& cmd, std::string& dir, std::string& identity) {
  cmd.add_option("--security", dir, "DDS Security: a `rig security init` directory (default: off)");
  cmd.add_option("--identity", identity, "DDS Security identity in that directory")->capture_default_str();
}
// Missing identity files are a usage error (exit 2), found before anything starts.
void check_security_options(const std::string& dir, const std::string& identity) {
  if (dir.empty()) return;
  try {
    (void)dds::security_files(dir, identity);
  } catch (const std::runtime_error& e) {
    throw cli::UsageError(e.what());
  }
}

}  // namespace

void register_dbw_cli(CLI::App& app, cli::Context& ctx) {
  auto& dbw = *app.add_subcommand("dbw", "Drive-by-wire: command source, bridge")->require_subcommand(1);
  auto so = std::make_shared<CommandSourceOptions>();
  auto* send = dbw.add_subcommand("send", "publish a fixed command on /vehicle/dbw/cmd at a rate, then stop");
  send->add_flag("--enable", so->enable, "request engagement (enable=false for the first 200 ms: an edge the bridge sees even if it matches this writer late)");
  send->add_option("--steer", so->steer, "road-wheel angle, rad (positive left)");
  send->add_option("--throttle", so->throttle, "0..1");
  send->add_option("--brake", so->brake, "0..1");
  send->add_option("--accel", so->accel, "m/s^2");
  send->add_option("--gear", so->gear, "0 keep, 1 park, 2 reverse, 3 neutral, 4 drive")->check(CLI::Range(0, 4));
  send->add_option("--rate", so->rate_hz, "Hz")->required()->check(CLI::PositiveNumber);
  send->add_option("--duration", so->duration_s, "seconds")->required()->check(CLI::NonNegativeNumber);
  send->add_option("--domain", so->domain, "DDS domain (default: ROS_DOMAIN_ID, else 0)")->check(CLI::Range(0, 232));
  send->add_option("--clock-offset", so->clock_offset_s,
                   "seconds added to every stamp, as if this process's clock were off (testing)");
  add_security_options(*send, so->security_dir, so->identity);
  send->callback([so, &ctx] {
    check_security_options(so->security_dir, so->identity);
    const auto n = run_command_source(*so);
    std::fprintf(stderr, "dbw send: %llu commands\n", static_cast<unsigned long long>(n));
    ctx.exit_code = cli::kOk;
  });

  auto bo = std::make_shared<BridgeOptions>();
  auto* br = dbw.add_subcommand("bridge", "the DBW bridge: /vehicle/dbw/cmd -> safety -> CAN; status and vehicle state out");
  br->add_option("config", bo->config, "protocol mapping YAML (positional form of --config)");
  br->add_option("--config", bo->config, "protocol mapping YAML (default: config/dbw/paravan_ref.yaml)");
  br->add_option("--transport", bo->transport, "CAN transport: unix:PATH (default /tmp/rig_paravan.sock), socketcan:IFACE, fd:N");
  br->add_option("--duration", bo->duration, "seconds to run (0 = until Ctrl-C)")->check(CLI::NonNegativeNumber);
  br->add_option("--domain", bo->domain, "DDS domain (default: ROS_DOMAIN_ID, else 0)")->check(CLI::Range(0, 232));
  add_security_options(*br, bo->security_dir, bo->identity);
  br->callback([bo, &ctx] {
    check_security_options(bo->security_dir, bo->identity);
    ctx.exit_code = run_bridge(*bo);
  });
}

}  // namespace sensor_rig::drivers
