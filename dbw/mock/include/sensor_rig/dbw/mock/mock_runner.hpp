#pragma once
// Runs a MockEcu on a transport: receives until the next 1 ms model tick, sends what the ECU emits,
// and logs every frame seen on the bus (both directions) as candump -L.
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

#include "sensor_rig/dbw/can/transport.hpp"
#include "sensor_rig/dbw/mock/mock_ecu.hpp"

namespace sensor_rig::dbw::mock {

struct RunOptions {
  double duration_s = 0.0;  // 0 = until shutdown
  std::string log_path;     // empty = no log
  std::string iface = "can0";
  int tick_ms = 1;
  bool print_state = false;  // one JSON line per second on stdout
  // Each frame the ECU made, once handed to the bus: whether another node heard it (Transport::
  // last_send_heard; false also when the send failed) and the vehicle time just before the send and
  // just after it returned. A receiver's kernel stamp is the send's instant, which lies between the
  // two: this process may be descheduled (or SIGSTOPped by host.stall_mock) before the send as well
  // as after it. rig chaos records both (a frame whose sender was preempted 5 ms before its send
  // otherwise had its sample judged the next frame's: "published twice", CI, dbw campaign seed 4).
  std::function<void(const can::Frame&, bool heard, Nanos handed_ns, Nanos returned_ns)> on_sent;
  // host.network_delay held in the mock (rig chaos, docs/faults.md): when a frame the ECU made at
  // `made_mono` (CLOCK_MONOTONIC) goes on the bus; at or before `made_mono`: at once. A frame never
  // leaves before one made earlier (they wait in order, as in a network's queue). Empty: at once.
  std::function<Nanos(const can::Frame&, Nanos made_mono)> depart;
};

struct RunResult {
  std::uint64_t logged = 0;
  std::uint64_t send_failures = 0;
};

RunResult run_mock(MockEcu& ecu, can::Transport& bus, const RunOptions& o);

}  // namespace sensor_rig::dbw::mock
