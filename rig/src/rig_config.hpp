#pragma once
// The rig's YAML configuration (config/*.yaml) as plain structs with defaults, validated on load:
// unknown keys, wrong types and bad values fail before anything starts, naming file:line and key.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/drivers/camera/camera_config.hpp"
#include "sensor_rig/drivers/dbw/dbw_config.hpp"
#include "sensor_rig/drivers/fusion/fusion_config.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "roudi_pools.hpp"
#include "sync_sets_config.hpp"

namespace sensor_rig::rig {

using drivers::DbwConfig;
using drivers::LidarConfig;
using drivers::LidarMockConfig;

struct RigConfig {
  std::string file;   // where it was loaded from
  std::string name = "rig";
  dds::DomainConfig dds;  // rig.dds: domain, profile, transport (udp | shm)
  std::string roudi_config;  // rig.dds.roudi_config: a RouDi TOML of one's own for shm (default: sized, roudi_pools.hpp)
  int shm_subscribers = 3;   // rig.dds.shm.subscribers: local subscribers per topic beyond the rig's own
  std::vector<Mempool> shm_mempools;  // rig.dds.shm.mempools: [{size, count}] instead of the sizing
  int diagnostics_period_ms = 1000;
  std::vector<LidarConfig> lidars;
  std::vector<drivers::CameraConfig> cameras;
  DbwConfig dbw;
  std::vector<SyncSetConfig> sync_sets;
  drivers::FusionConfig fusion;  // fusion: the LIDARs as one cloud in base_link
};

// Loads and validates; throws ConfigError listing every problem (file:line:col: key: message).
RigConfig load_rig_config(const std::string& path);
// Human-readable summary for `rig config check`.
std::string describe(const RigConfig& cfg);
// Its shared-memory part: the RouDi mempools rig up uses (one line).
std::string describe_shm(const RigConfig& cfg);

}  // namespace sensor_rig::rig
