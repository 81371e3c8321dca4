// `rig mock paravan [--transport SPEC] [--config YAML] [--log FILE] [--fault SPEC]... [--duration S]`
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "dbw_commands.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"

namespace sensor_rig::dbw {
namespace {

struct MockOptions {
  std::string transport = std::string("unix-listen:") + kDefaultBusSocket;
  std::string config;
  std::string log;
  std::vector<std::string> faults;
  double duration = 0.0;
  std::uint64_t seed = 1;
  bool print_state = false;
};

int run_mock_paravan(const MockOptions& o) {
  const Protocol protocol = Protocol::load(o.config.empty() ? default_protocol_config() : o.config);
  std::vector<mock::Fault> faults;
  for (const auto& f : o.faults) {
    try {
      faults.push_back(mock::parse_fault(f));
    } catch (const std::invalid_argument& e) {
      throw cli::UsageError(std::string("--fault: ") + e.what());
    }
  }
  std::unique_ptr<can::Transport> bus;
  try {
    bus = can::open_transport(o.transport);
  } catch (const can::TransportError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return cli::kUsage;
  }
  mock::RunOptions ro;
  ro.duration_s = o.duration;
  ro.log_path = o.log;
  if (ro.log_path.empty()) {
    if (const char* dir = std::getenv("RIG_LOG_DIR"); dir != nullptr && *dir != '\0') {
      ro.log_path = std::string(dir) + "/dbw_bus.log";
    }
  }
  ro.print_state = o.print_state;
  mock::MockEcu ecu(protocol, std::move(faults), o.seed);
  std::fprintf(stderr, "mock paravan: %s, protocol %s (hash %s)%s%s\n", bus->name().c_str(),
               protocol.mapping_path().c_str(), protocol.config_hash().c_str(), ro.log_path.empty() ? "" : ", log ",
               ro.log_path.c_str());
  const auto r = mock::run_mock(ecu, *bus, ro);
  const auto& c = ecu.counters();
  std::fprintf(stderr, "mock paravan: rx %llu (e2e errors %llu), tx %llu (dropped %llu), pu timeouts %llu, logged %llu\n",
               static_cast<unsigned long long>(c.rx_frames), static_cast<unsigned long long>(c.rx_e2e_errors),
               static_cast<unsigned long long>(c.tx_frames), static_cast<unsigned long long>(c.tx_dropped),
               static_cast<unsigned long long>(c.pu_timeouts), static_cast<unsigned long long>(r.logged));
  return cli::kOk;
}

}  // namespace

void register_mock_cli(CLI::App& mock, cli::Context& ctx) {
  auto o = std::make_shared<MockOptions>();
  auto* p = mock.add_subcommand("paravan", "mock Paravan ECU + vehicle model on a CAN transport");
  p->add_option("--transport", o->transport,
                "bus: unix-listen:PATH (default, the bridge connects with unix:PATH), socketcan:IFACE, fd:N");
  p->add_option("--config", o->config, "protocol mapping YAML (default: config/dbw/paravan_ref.yaml)");
  p->add_option("--log", o->log, "write every frame on the bus (both directions) as candump -L; default $RIG_LOG_DIR/dbw_bus.log");
  p->add_option("--fault", o->faults, "loss=P | bad-crc | stuck-counter | override | ecu-fault | bus-off | no-status, each [@START_S][+DURATION_S]");
  p->add_option("--duration", o->duration, "seconds to run (0 = until Ctrl-C)")->check(CLI::NonNegativeNumber);
  p->add_option("--seed", o->seed, "random seed for frame loss");
  p->add_flag("--print-state", o->print_state, "one JSON line per second with the vehicle state");
  p->callback([o, &ctx] { ctx.exit_code = run_mock_paravan(*o); });
}

}  // namespace sensor_rig::dbw
