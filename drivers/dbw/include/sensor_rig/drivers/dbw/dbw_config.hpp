#pragma once
// The drive-by-wire section of a rig config (`dbw:`) and its parser.
#include <string>
#include <vector>

#include "sensor_rig/common/config_node.hpp"

namespace sensor_rig::drivers {

// Drive-by-wire: the bridge (`rig dbw bridge`) and, on the mock rig, the mock Paravan ECU and a
// simple command source, each its own process.
struct DbwConfig {
  bool enabled = false;
  std::string protocol;                 // mapping YAML (default: config/dbw/paravan_ref.yaml)
  std::string bus = "/tmp/rig_paravan.sock";  // unix seqpacket bus path (mock) ...
  std::string transport;                // ... or an explicit bridge transport (socketcan:can0); empty = unix:<bus>
  bool mock_ecu = false;
  int realtime_priority = 30;           // SCHED_FIFO for bridge, mock ECU and command source; 0 = normal
  std::vector<std::string> mock_faults;  // `rig mock paravan --fault` values
  struct CommandSource {
    bool enabled = false;
    double rate_hz = 50;
    double steer_rad = 0.05;
    double throttle = 0.2;
    double brake = 0.0;
    int gear = 4;
  } command_source;
  // DDS Security on /vehicle/dbw/cmd (`security: {dir: DIR}`): the bridge and the command source run
  // as these identities of a `rig security init` directory; the rig's other nodes stay ordinary.
  struct Security {
    bool enabled = false;
    std::string dir;
    std::string bridge_identity = "dbw_bridge";
    std::string command_identity = "dbw_command";
  } security;
};

// `--security DIR --identity NAME` for the bridge (bridge = true) or the command source; empty when off.
std::vector<std::string> security_args(const DbwConfig& d, bool bridge);

// Parses the `dbw:` map; problems go to the node's problem list (reported all at once).
DbwConfig parse_dbw_config(const config::Node& n);

}  // namespace sensor_rig::drivers
