#pragma once
// What one `rig perf run` measures (SPEC §9): topology, node count, payload size, rate, duration,
// transport; and the plan derived from it (which node publishes or subscribes which topic).
// Pure: no I/O, no DDS. Parsing throws cli::UsageError with the offending value.
#include <cstdint>
#include <string>
#include <vector>

namespace sensor_rig::bench::perf {

enum class Transport { kUdp, kUdpTuned, kShm };
// fixed: fixed-size struct per size class (loanable); seq: header + sequence<octet>; pointcloud2: the
// sensor_msgs/PointCloud2 the LIDAR driver publishes (24-byte points, S bytes of data).
enum class Message { kFixed, kSeq, kPointCloud2 };
enum class Role { kPublisher, kSubscriber };
// How pointcloud2 subscribers read: copy (dds_take deserializes data into a fresh buffer, as a ROS 2
// node does) or view (the serialized sample read in place: dds/view_reader.hpp).
enum class ReaderMode { kCopy, kView };

// The size classes of the paper (binary multiples): 0B 16B 64kB 512kB 1MB 2MB.
std::uint32_t parse_size(const std::string& text);  // "64kB" -> 65536; only the classes above
std::string size_label(std::uint32_t bytes);        // 65536 -> "64kB"
bool is_size_class(std::uint32_t bytes);
Transport parse_transport(const std::string& text);
std::string to_string(Transport t);
Message parse_message(const std::string& text);
std::string to_string(Message m);
ReaderMode parse_reader_mode(const std::string& text);
std::string to_string(ReaderMode r);

struct RunSpec {
  int topology = 2;           // 1, 2 or 3
  int nodes = 2;              // processes
  std::uint32_t size = 0;     // payload bytes
  double rate_hz = 10.0;
  double duration_s = 60.0;
  Transport transport = Transport::kUdp;
  Message message = Message::kFixed;
  ReaderMode reader = ReaderMode::kCopy;  // view: pointcloud2 only
  int domain = -1;            // -1: derived from the runner's pid
  int depth = 10;             // keep-last depth (ROS 2 default QoS: reliable, keep-last 10, volatile)
  int rt_priority = 0;        // > 0: nodes run SCHED_FIFO at this priority
  std::string out;            // output directory

  [[nodiscard]] std::uint32_t count() const;  // messages per publisher: rate x duration, rounded
  [[nodiscard]] std::string label() const;    // "T2 N=32 1MB 10Hz shm" (+ " pointcloud2"/" seq", + " view")
  void validate() const;                      // throws cli::UsageError
};

struct NodePlan {
  int index = 0;
  Role role = Role::kPublisher;
  std::vector<int> topics;  // publisher: exactly one; subscriber: one or more
  int expected_matches = 0; // publisher: readers on its topic; subscriber: one writer per topic
};

// Topology 1: N/2 publishers, each with its own topic and one subscriber node (N even).
// Topology 2: 1 publisher, N-1 subscriber nodes on its topic.
// Topology 3: N-1 publishers with one topic each, one subscriber node subscribing to all of them.
std::vector<NodePlan> plan_nodes(const RunSpec& spec);
int publisher_count(const RunSpec& spec);

}  // namespace sensor_rig::bench::perf
