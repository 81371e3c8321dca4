#pragma once
// `rig lidar replay --fault-plan / --fault`: the fault vocabulary's events of this device turned
// into what the mock does: the sensor's own faults (vehicle time) and the network's (schedule
// offsets), plus the fault lines of its truth record. Throws cli::UsageError naming the problem.
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/lidar/mock/packet_fields.hpp"
#include "sensor_rig/lidar/mock/scheduled_faults.hpp"
#include "sensor_rig/lidar/mock/sensor_faults.hpp"
#include "sensor_rig/lidar/mock/truth_stream.hpp"

namespace sensor_rig::lidar {

struct ReplayFaultInput {
  std::string device;
  std::string plan_path;            // events relative to the plan's epoch_mono_ns
  std::vector<std::string> specs;   // relative to `start_mono_ns`
  Nanos start_mono_ns = 0;          // the replay's start (CLOCK_MONOTONIC)
  Nanos first_deadline_mono_ns = 0; // schedule offset 0
  Nanos mono_to_vehicle_ns = 0;     // vehicle = monotonic + this
  double horizon_s = 86400.0;
};

struct ReplayFaults {
  std::vector<mock::SensorFault> sensor;
  std::vector<mock::NetFault> network;
  std::vector<mock::FaultNote> notes;
  [[nodiscard]] bool empty() const noexcept { return sensor.empty() && network.empty(); }
};

// `fields`: the synthetic sensor's packet layout (nullopt: a capture, where only field=byte exists).
ReplayFaults replay_faults(const ReplayFaultInput& in, const std::optional<mock::PacketFields>& fields);

}  // namespace sensor_rig::lidar
