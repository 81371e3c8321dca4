#pragma once
// `rig record`: every discovered ROS topic (or those named) into MCAP as rosbag2 writes it, the CDR
// bytes as received (dds/raw_topic.hpp) and no decode. Two threads: this one takes samples from
// DDS and queues them (no copy: over shm the queue holds the iceoryx chunks themselves); a writer
// thread copies each into the chunk being filled, compresses and writes (record/split_writer.hpp).
// Nothing is dropped silently: DDS's lost/rejected samples, samples announced on /rig/stamps that
// never came (record_gaps.hpp: Cyclone does not report those), samples the queue had no room for (the
// writer thread behind: its compress/write time split tells which), and samples a failed file could
// not take are counted per topic, shown once a second on stderr and in the summary at the end.
#include <cstdint>
#include <string>
#include <vector>

#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::rig {

struct RecordOptions {
  std::vector<std::string> topics;  // ROS names; empty: every topic discovered
  std::string out;                  // NAME.mcap, or a folder when splitting
  double duration_s = 0;            // 0: until SIGINT/SIGTERM
  dds::DomainConfig dds;
  record::Compression compression = record::Compression::kZstd;
  std::uint64_t split_mb = 0;
  double split_s = 0;
  std::size_t chunk_kb = 4096;      // uncompressed bytes per chunk
  std::size_t queue_mb = 256;       // bytes queued between the DDS thread and the writer at most
  std::size_t topic_queue = 128;    // over shm: samples (= the publishers' chunks) queued per topic at most
  bool progress = true;             // a line on stderr once a second
  int rt_priority = 0;              // > 0: the DDS thread, the writer thread and Cyclone's threads SCHED_FIFO
  // The raw channels (LIDAR packets, CAN frames: is_raw_channel) too; without, only when named.
  bool raw = false;
};

// A type whose topics are raw channels: the drivers publish them only while a reader is matched,
// so recording every discovered topic must not turn them on unless asked (--raw).
bool is_raw_channel(const std::string& schema_name);

// Records until the duration, a signal, or a file error. Prints the summary (JSON, one line) on
// stdout. Returns the exit code: 0, or 1 when the file failed (the reason on stderr).
int run_record(const RecordOptions& options);

}  // namespace sensor_rig::rig
