#pragma once
// iceoryx RouDi mempools for `rig up` with rig.dds.transport: shm, sized from the rig config.
// Every shared-memory write takes one chunk from the smallest pool it fits (no fallback to a larger
// pool): a sample larger than the largest pool, or a pool out of chunks, makes dds_write fail.
// So one pool per size class of the rig's large messages (LIDAR clouds at their model's most
// points, the fused cloud, camera images), each with the chunks its topics can hold at once:
//   per topic: writers x (1 loan + pub history) + readers x (keep-last depth + 1 being taken),
// times 1.5 plus 2, and two pools for the small messages (stamps, diagnostics, dbw, camera_info).
// `rig.dds.shm.mempools: [{size, count}]` replaces the sizing (validated: ascending sizes, the
// largest sample fits), `rig.dds.roudi_config: FILE` replaces the whole RouDi configuration.
#include <cstdint>
#include <string>
#include <vector>

namespace sensor_rig::rig {

struct RigConfig;

struct Mempool {
  std::uint64_t size = 0;   // chunk payload bytes (iceoryx adds its chunk header)
  std::uint64_t count = 0;  // chunks
  bool operator==(const Mempool&) const = default;
};

// One shared-memory topic's worst case: its largest serialised sample and who holds its chunks.
struct ShmTopicLoad {
  std::string topic;
  std::uint64_t max_sample_bytes = 0;  // CDR sample (headers, strings, data)
  int writers = 1;
  int pub_history = 0;                 // transient-local writers keep their last depth samples
  int readers = 1;                     // local shared-memory subscribers
  int depth = 1;                       // their keep-last depth
};

inline constexpr std::uint64_t kSmallPool = 1024;         // stamps, dbw, camera_info
inline constexpr std::uint64_t kMediumPool = 16 * 1024;   // diagnostics, compressed thumbnails
inline constexpr int kMaxMempools = 32;                   // iceoryx 2.0 MAX_NUMBER_OF_MEMPOOLS
inline constexpr std::uint64_t kChunkOverhead = 256;      // Cyclone's iceoryx header + alignment

// What a rig config's topics ask of shared memory; `extra_subscribers` local subscribers beyond
// the rig's own (a monitor, ROS 2 nodes) on every topic.
std::vector<ShmTopicLoad> shm_topic_loads(const RigConfig& cfg, int extra_subscribers);
// The chunk size a sample of `bytes` needs: + Cyclone's iceoryx header and alignment, rounded up to
// 1/8 of its power of two (so similar sizes share a pool, at most 12.5 % wasted).
std::uint64_t chunk_size_for(std::uint64_t sample_bytes);
// Pools for these loads, ascending by size, plus the two small pools.
std::vector<Mempool> size_mempools(const std::vector<ShmTopicLoad>& loads);
// The mempools rig up uses: rig.dds.shm.mempools, else size_mempools(shm_topic_loads(cfg, ...)).
std::vector<Mempool> rig_mempools(const RigConfig& cfg);
std::uint64_t mempools_bytes(const std::vector<Mempool>& pools);

// RouDi's TOML (iceoryx 2.0 config file, one segment) and back (for a running RouDi's -c file).
std::string roudi_toml(const std::vector<Mempool>& pools, const std::string& comment);
std::vector<Mempool> parse_roudi_toml(const std::string& text);
// iceoryx 2.0's built-in pools (RouDi without -c).
std::vector<Mempool> iceoryx_default_mempools();

// Whether `available` serves `required` (each required pool's chunks land in the smallest
// available pool they fit, as iceoryx picks); empty when it does, else what falls short, in words.
std::string mempools_shortfall(const std::vector<Mempool>& required, const std::vector<Mempool>& available);

// The -c/--config-file of a running iox-roudi (from /proc/PID/cmdline); empty when it has none.
std::string roudi_config_file_of(int pid);

}  // namespace sensor_rig::rig
