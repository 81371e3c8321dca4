#pragma once
// The DDS side of the bridge: rt/vehicle/dbw/cmd -> BridgeCore -> CAN transport; ECU frames ->
// rt/vehicle/state; every state change/fault and 10 Hz -> rt/vehicle/dbw/status; per command
// rt/rig/stamps (command stamp -> received -> CAN frames written); 1 Hz /diagnostics.
// Three threads: the DDS reader sends the frames of a fresh command at once within the bus
// schedule (low latency); the CAN loop receives ECU frames and ticks every millisecond (timeouts,
// repeat/neutral frames, heartbeat); a publisher thread does every DDS write of status, state,
// stamps and diagnostics, so the control path never waits on them. Stopping (duration, SIGINT,
// SIGTERM) disengages first: neutral frames for a few periods, then the end.
#include <cstdint>
#include <string>

#include "sensor_rig/dbw/bridge/protocol.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::drivers {

struct DdsBridgeOptions {
  double duration_s = 0.0;  // 0 = until shutdown
  bool print_stats = true;  // summary on stderr at the end
  int domain = -1;          // DDS domain; -1: ROS_DOMAIN_ID or 0
  int neutral_periods_on_stop = 3;  // neutral frame sets sent when stopping
  std::string security_dir;         // DDS Security (`rig security init` directory); empty: off
  std::string identity = "dbw_bridge";
};

struct DdsBridgeStats {
  std::uint64_t commands = 0;
  std::uint64_t frames_sent = 0;
  // Command sample source timestamp -> its CAN frames written (ns), and take -> written.
  double latency_p50_us = 0.0, latency_p99_us = 0.0, latency_max_us = 0.0;
  double take_to_send_p50_us = 0.0, take_to_send_p99_us = 0.0;
  // Last command received -> first neutral frame after a command timeout (ms); <0 when none happened.
  double silence_to_neutral_ms = -1.0;
  std::uint64_t status_published = 0;
  std::uint64_t state_published = 0;
  bool transport_closed = false;  // the CAN transport went away before the end (a runtime failure)
  std::uint64_t commands_deferred = 0;   // held for the bus schedule (command rate above it)
  std::uint64_t neutral_sets_on_stop = 0;
  std::uint64_t outbox_dropped = 0;      // status/stamps items the publisher could not keep up with
  // CPU time of the bridge's own two threads (DDS reader + CAN loop), not Cyclone's threads.
  double bridge_threads_cpu_s = 0.0;
};

DdsBridgeStats run_dds_bridge(const dbw::Protocol& protocol, dbw::can::Transport& bus, const DdsBridgeOptions& o);

struct CommandSourceOptions {
  bool enable = false;
  double steer = 0.0;
  double throttle = 0.0;
  double brake = 0.0;
  double accel = 0.0;
  int gear = 0;
  double rate_hz = 50.0;
  double duration_s = 1.0;
  double wait_for_reader_s = 2.0;  // wait this long for the bridge to match before sending
  bool enable_edge = true;         // with --enable: enable=false for the first 200 ms so the bridge sees an edge
  int domain = -1;                 // DDS domain; -1: ROS_DOMAIN_ID or 0
  double clock_offset_s = 0.0;     // added to every stamp (tests: a process whose clock is off)
  std::string security_dir;        // DDS Security (`rig security init` directory); empty: off
  std::string identity = "dbw_command";
};
// Publishes commands on rt/vehicle/dbw/cmd; returns the number sent.
std::uint64_t run_command_source(const CommandSourceOptions& o);

}  // namespace sensor_rig::drivers
