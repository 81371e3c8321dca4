#pragma once
// rig/time in /diagnostics: the PU's own clock, which every stamp of the rig is in. Two things:
//  - PTP state from linuxptp's `pmc -u -b 0 'GET TIME_STATUS_NP'` (run off the diagnostics loop,
//    with a timeout, every poll period); where pmc or ptp4l is absent (this VM) the state is a plain
//    "not synchronized", an error level only where PTP answers and is off;
//  - CLOCK_REALTIME steps while running (NTP/PTP corrections, `date -s`): counted, last and total
//    size, each logged once.
// Which pmc runs: $RIG_PMC if set (a path, or a script replaying recorded output in tests), else
// `pmc` on PATH.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sensor_rig/dds/driver_status.hpp"

namespace sensor_rig::rig {

struct HostTimeOptions {
  std::string pmc = "pmc";              // program; $RIG_PMC overrides the default
  int poll_period_ms = 10'000;          // how often pmc runs
  int pmc_timeout_ms = 2'000;           // a hung pmc is killed after this
  std::int64_t max_offset_ns = 1'000;   // |master offset| for "synchronized"
};

// `pmc` from $RIG_PMC when set, else `fallback`.
std::string pmc_program(const std::string& fallback = "pmc");

class HostTimeNode {
 public:
  explicit HostTimeNode(HostTimeOptions options);
  ~HostTimeNode();
  HostTimeNode(const HostTimeNode&) = delete;
  HostTimeNode& operator=(const HostTimeNode&) = delete;
  void start();  // the pmc poller thread; the first poll runs at once
  void stop();
  // Observes the realtime clock and appends the rig/time status (call from the diagnostics loop).
  void supervise(std::vector<dds::DriverStatus>& statuses);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::rig
