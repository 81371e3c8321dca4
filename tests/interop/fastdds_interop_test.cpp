// ROS 2 nodes with rmw_fastrtps receive every LIDAR scan the rig writes, whole — and where Fast DDS
// 2.9 itself breaks (docs/foreign-subscribers.md). The readers are Fast DDS processes
// (fastdds_pointcloud_sub: what rmw_fastrtps sets, ROS 2's QoS, samples taken on the main thread
// after a WaitSet wakes, as an executor does):
// - DefaultRos2SubscribersReceiveEveryScan: the writer is what the rig's LIDAR node makes for
//   config/mock_rig.yaml's front LIDAR (its QoS, the rig's Cyclone profile, 1.2 MB PointCloud2 at
//   10 Hz); at once, ROS 2's default QoS (reliable, keep-last 10) on Fast DDS's defaults (OS socket
//   buffers, 208 kB: it loses most of each burst and lives on repairs, config/cyclonedds/loopback.xml)
//   and ROS 2's sensor-data QoS (best effort, keep-last 5) with the subscriber profile (a
//   best-effort reader gets no repair, so only its own socket buffer keeps the scan).
// - OneNodeReadsEveryCloudOfThePhaseLockedRig: one node reading the four clouds of a running,
//   phase-locked rig (6.4 MB within ~5 ms every sweep) in the configuration the page gives for it
//   (the node: ROS 2's default QoS and config/fastdds/ros2_subscriber_loopback.xml; the rig's cloud
//   writers: keep-last 10): every scan from its first, whole, in order, none missing.
// - AGapForAHalfReassembledSampleMakesFastDdsHandOutAPhantom: the Fast DDS defect such a node meets
//   when it falls behind (its repairs outlast the writer's keep-last history, so the writer answers
//   with a GAP for a sample whose fragments are half in), made to happen by sending the RTPS
//   submessages themselves, so it does not depend on timing.
// Every node is localhost-only (ROS_LOCALHOST_ONLY=1 or the loopback profile): the rig's DDS is on
// `lo`, and a Fast DDS participant on a host with another interface up announces that interface,
// which Cyclone on `lo` cannot reach. Each test removes the /dev/shm files its Fast DDS processes
// left. Run by hand, the executable finds the source tree and `rig` itself (RIG_SOURCE_DIR and
// RIG_BIN override, as ctest sets them) and says what is missing.
// Measuring: RIG_INTEROP_SCANS=200 for longer runs; RIG_INTEROP_BE_PROFILE= (empty) runs the
// best-effort reader on Fast DDS's defaults too (it then loses most scans: what the profile is for);
// RIG_INTEROP_RIG_PROFILE= (empty) runs the phase-locked node on Fast DDS's defaults (208 kB, with
// ROS_LOCALHOST_ONLY=1), RIG_INTEROP_RIG_DEPTH=2 its rig with the shipped writers' keep-last 2.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dds_domain_lease.hpp"
#include "rig_process.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "test_data.hpp"

namespace sensor_rig {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// 4 s at 10 Hz, or RIG_INTEROP_SCANS.
int scan_count() {
  const char* n = std::getenv("RIG_INTEROP_SCANS");
  return n != nullptr && *n != '\0' ? std::atoi(n) : 40;
}
constexpr int kPoints = 51460;  // the mock VLP-32C's scan: 1.2 MB
constexpr auto kPeriod = std::chrono::milliseconds(100);
// Discovery, matching and the first sample on a cold or loaded host: a bound, not a window.
constexpr int kWaitS = 60;

// Where the source tree, `rig` and the subscriber are: ctest sets RIG_SOURCE_DIR and RIG_BIN; run
// by hand, the build's own paths (compiled in). Anything missing is said, not dereferenced.
struct Paths {
  fs::path source;
  std::string rig;
  std::string sub = FASTDDS_POINTCLOUD_SUB;
  std::string problem;
};

Paths paths() {
  Paths p;
  const char* s = std::getenv("RIG_SOURCE_DIR");
  p.source = s != nullptr && *s != '\0' ? fs::path(s) : fs::path(RIG_INTEROP_SOURCE_DIR);
  const char* r = std::getenv("RIG_BIN");
  p.rig = r != nullptr && *r != '\0' ? r : RIG_INTEROP_RIG_BIN;
  if (!fs::exists(p.source / "config/mock_rig.yaml"))
    p.problem =
        "no config/mock_rig.yaml in '" + p.source.string() + "': set RIG_SOURCE_DIR to the source tree (ctest sets it)";
  else if (::access(p.rig.c_str(), X_OK) != 0)
    p.problem = "no rig binary at '" + p.rig + "': build it (make rig) or set RIG_BIN (ctest sets it)";
  else if (::access(p.sub.c_str(), X_OK) != 0)
    p.problem = "no fastdds_pointcloud_sub at '" + p.sub + "': build it (make fastdds_pointcloud_sub)";
  return p;
}

// The front LIDAR of the mock rig: its writer QoS and the rig's Cyclone profile, as `rig up` reads them.
struct RigWriterConfig {
  drivers::LidarConfig lidar;
  std::string profile;
};

std::optional<RigWriterConfig> mock_rig_front(const fs::path& source, std::string& why) {
  auto problems = std::make_shared<config::Problems>();
  const std::string file = (source / "config/mock_rig.yaml").string();
  const auto root = config::Node::load_file(file, problems);
  const auto rig = root.child("rig", true);
  const auto dds = rig ? rig->child("dds", true) : std::nullopt;
  const auto lidars = root.items("lidars", true);
  if (!dds || lidars.empty() || !problems->empty()) {
    why = file + ": no rig.dds or lidars[0]: " + problems->str();
    return std::nullopt;
  }
  RigWriterConfig c;
  c.profile = dds->get_path("profile");
  c.lidar = drivers::parse_lidar_config(lidars.front());
  if (!problems->empty()) {
    why = problems->str();
    return std::nullopt;
  }
  return c;
}

// Fast DDS keeps shared-memory files in /dev/shm; a process that is killed or aborts leaves them.
// Whatever appeared while this lived is removed when it goes (declare it before the nodes).
class FastDdsShmGuard {
 public:
  FastDdsShmGuard() : before_(list()) {}
  FastDdsShmGuard(const FastDdsShmGuard&) = delete;
  FastDdsShmGuard& operator=(const FastDdsShmGuard&) = delete;
  ~FastDdsShmGuard() {
    for (const auto& f : list())
      if (before_.count(f) == 0) {
        std::error_code ec;
        fs::remove(fs::path("/dev/shm") / f, ec);
      }
  }

 private:
  static std::set<std::string> list() {
    std::set<std::string> names;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator("/dev/shm", ec)) {
      const std::string n = e.path().filename().string();
      if (n.rfind("fastrtps_", 0) == 0 || n.rfind("sem.fastrtps_", 0) == 0) names.insert(n);
    }
    return names;
  }
  std::set<std::string> before_;
};

// A reader's endpoints, as the node prints them when it matches a writer.
struct Endpoints {
  std::string topic;
  std::string writer_guid;  // 32 hex digits, as on the wire
  std::string reader_guid;
  int udp_port = 0;  // the reader's unicast port on 127.0.0.1
};

struct NodeResult {
  ExitInfo exit;
  std::vector<nlohmann::json> topics;  // one summary per topic
  std::string stderr_hint;             // what to look for when it did not exit 0
};

// One ROS 2 node (fastdds_pointcloud_sub), reading one or more topics.
class FastDdsNode {
 public:
  struct Options {
    std::vector<std::string> topics;
    int domain = 0;
    std::string qos = "default";  // or sensor_data
    int count = 1;                // whole scans per topic
    std::string profile;          // FASTRTPS_DEFAULT_PROFILES_FILE; empty: Fast DDS's defaults ...
    bool localhost_only = true;   // ... with ROS_LOCALHOST_ONLY=1 (no profile only)
    std::string take_in = "executor";
    int timeout_s = 30;  // from the first sample
    int quiet_ms = 3000;
  };

  FastDdsNode(const Paths& where, const Options& o) : options_(o) {
    ChildOptions c;
    c.pipe_stdio = true;
    c.env.push_back("SKIP_DEFAULT_XML=1");  // no DEFAULT_FASTRTPS_PROFILES.xml from the working directory
    if (o.profile.empty())
      ::unsetenv("FASTRTPS_DEFAULT_PROFILES_FILE");  // ours, not the caller's: Fast DDS's defaults
    else
      c.env.push_back("FASTRTPS_DEFAULT_PROFILES_FILE=" + o.profile);
    std::vector<std::string> argv = {where.sub,
                                     "--domain",
                                     std::to_string(o.domain),
                                     "--qos",
                                     o.qos,
                                     "--count",
                                     std::to_string(o.count),
                                     "--take-in",
                                     o.take_in,
                                     "--localhost-only",
                                     o.profile.empty() && o.localhost_only ? "1" : "0",
                                     "--wait-s",
                                     std::to_string(kWaitS),
                                     "--timeout-s",
                                     std::to_string(o.timeout_s),
                                     "--quiet-ms",
                                     std::to_string(o.quiet_ms)};
    for (const auto& t : o.topics) argv.insert(argv.end(), {"--topic", t});
    child_ = ChildProcess(argv, c);
  }

  // True once every reader matched a writer (Fast DDS drops data of writers it has not matched).
  bool wait_matched(int timeout_ms) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (endpoints_.size() < options_.topics.size() && Clock::now() < deadline && child_.running()) {
      poll();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    poll();
    return endpoints_.size() >= options_.topics.size();
  }
  [[nodiscard]] const std::vector<Endpoints>& endpoints() const { return endpoints_; }

  // Until it exits by itself (it bounds its own waits), at most timeout_ms.
  NodeResult finish(int timeout_ms) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!child_.stdout_eof() && Clock::now() < deadline) {
      poll();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    poll();
    child_.wait_exit(5000);
    child_.stop();
    NodeResult r;
    r.exit = child_.exit_info();
    r.topics = summaries_;
    if (r.exit.term_signal == SIGABRT) r.stderr_hint = "it aborted: Fast DDS's assertion is on stderr above";
    return r;
  }

 private:
  void poll() {
    for (const auto& l : child_.read_lines()) {
      if (!l.empty() && l.front() == '{') {
        summaries_.push_back(nlohmann::json::parse(l, nullptr, false));
      } else if (l.rfind("matched ", 0) == 0) {
        std::istringstream in(l.substr(8));
        Endpoints e;
        std::string w, rd, udp;
        in >> e.topic >> w >> e.writer_guid >> rd >> e.reader_guid >> udp >> e.udp_port;
        endpoints_.push_back(e);
      }
    }
  }

  Options options_;
  ChildProcess child_;
  std::vector<Endpoints> endpoints_;
  std::vector<nlohmann::json> summaries_;
};

std::string describe(const ExitInfo& e) {
  return e.exited ? "exit " + std::to_string(e.exit_code) : "signal " + std::to_string(e.term_signal);
}

// Every scan the writer sent, whole, nothing else.
void expect_every_scan(const NodeResult& r, const std::set<std::int64_t>& sent, const char* reader,
                       std::uint32_t udp_buffer) {
  const int scans = static_cast<int>(sent.size());
  ASSERT_EQ(r.topics.size(), 1u) << reader << ": no summary (" << describe(r.exit) << ") " << r.stderr_hint;
  const nlohmann::json& j = r.topics.front();
  ASSERT_FALSE(j.is_discarded()) << reader << ": summary unreadable";
  EXPECT_EQ(j["udp_receive_buffer"].get<std::uint32_t>(), udp_buffer) << reader;
  std::cout << reader << ": " << j["whole"] << " of " << sent.size() << " scans whole, " << j["broken"] << " broken, "
            << j["phantom"] << " phantom, " << j["lost_reported"] << " reported lost, slowest " << j["max_delay_ms"]
            << " ms after its stamp\n";
  std::set<std::int64_t> got;
  for (const auto& s : j["stamps"]) got.insert(s.get<std::int64_t>());
  EXPECT_EQ(got, sent) << reader;
  EXPECT_EQ(j["whole"].get<int>(), scans) << reader;
  EXPECT_EQ(j["broken"].get<int>(), 0) << reader;
  EXPECT_EQ(j["phantom"].get<int>(), 0) << reader;
  EXPECT_TRUE(r.exit.exited && r.exit.exit_code == 0) << reader << ": " << describe(r.exit) << " " << r.stderr_hint;
}

TEST(FastDdsInterop, DefaultRos2SubscribersReceiveEveryScan) {
  const Paths where = paths();
  ASSERT_TRUE(where.problem.empty()) << where.problem;
  std::string why;
  const auto rig = mock_rig_front(where.source, why);
  ASSERT_TRUE(rig) << why;
  FastDdsShmGuard shm;
  const int domain = sensor_rig::test::lease_dds_domain();  // private to this run
  const std::string ros_topic = "/sensors/lidar/interop_" + std::to_string(::getpid()) + "/points";
  dds::Participant p(dds::DomainConfig{static_cast<dds_domainid_t>(domain), rig->profile});
  dds::Topic<msg::PointCloud2> topic(p, ros_topic, rig->lidar.qos);
  dds::Writer<msg::PointCloud2> writer(p, topic, rig->lidar.qos);

  const int scans = scan_count();
  FastDdsNode::Options o;
  o.topics = {dds::ros_to_dds_topic(ros_topic)};
  o.domain = domain;
  o.count = scans;
  o.timeout_s = scans / 10 + 20;
  FastDdsNode reliable(where, o);
  const char* be_env = std::getenv("RIG_INTEROP_BE_PROFILE");
  o.qos = "sensor_data";
  o.profile = be_env != nullptr ? be_env : (where.source / "config/fastdds/ros2_subscriber_loopback.xml").string();
  FastDdsNode best_effort(where, o);
  ASSERT_TRUE(reliable.wait_matched(kWaitS * 1000))
      << "the reliable Fast DDS reader matched no writer in " << kWaitS << " s";
  ASSERT_TRUE(best_effort.wait_matched(kWaitS * 1000))
      << "the best-effort Fast DDS reader matched no writer in " << kWaitS << " s";
  // Matched on their side; on ours too before the first (volatile) scan.
  ASSERT_TRUE(writer.wait_for_readers(2, kWaitS * 1000))
      << "the Fast DDS readers were not discovered in " << kWaitS << " s";

  std::vector<lidar::PointXYZIRT> points(kPoints);
  const auto fields = msg::point_fields(lidar::kPointFields);
  msg::PointCloud2 pc{};
  pc.header.frame_id = const_cast<char*>("lidar_front");  // the C type is not const-correct
  pc.height = 1;
  pc.width = kPoints;
  pc.fields._buffer = const_cast<msg::PointField*>(fields.data());
  pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(fields.size());
  pc.point_step = sizeof(lidar::PointXYZIRT);
  pc.row_step = pc.point_step * pc.width;
  pc.data._buffer = reinterpret_cast<std::uint8_t*>(points.data());
  pc.data._length = pc.data._maximum = pc.row_step;
  pc.is_dense = true;

  std::set<std::int64_t> sent;
  Nanos longest_write = 0;  // a reliable writer blocks when its history is full of unacknowledged data
  auto next = Clock::now();
  for (int i = 0; i < scans; ++i) {
    const Nanos stamp = vehicle_now_ns();
    pc.header.stamp = msg::to_time(stamp);
    for (auto& pt : points) pt.t = static_cast<std::uint32_t>(i);  // a new scan's contents
    const Nanos before = monotonic_now_ns();
    const dds::Result written = writer.write(pc, stamp);
    longest_write = std::max(longest_write, monotonic_now_ns() - before);
    ASSERT_TRUE(written.ok()) << "scan " << i << ": " << written.message();
    sent.insert(stamp);
    next += kPeriod;
    std::this_thread::sleep_until(next);
  }
  std::cout << "longest write " << static_cast<double>(longest_write) / 1e6 << " ms\n";
  const int finish_ms = (o.timeout_s + 10) * 1000;
  expect_every_scan(reliable.finish(finish_ms), sent, "reliable keep-last 10 (ROS 2 default)", 0);
  expect_every_scan(best_effort.finish(finish_ms), sent, "best effort keep-last 5 (ROS 2 sensor data)",
                    o.profile.empty() ? 0 : 4u << 20);
}

// One ROS 2 node subscribed to all four clouds of a running rig whose three LIDARs are phase-locked:
// their scans (1.2, 0.5 and 1.5 MB) and then the 3.2 MB fused cloud all arrive within ~5 ms, 64 MB/s.
// In the configuration docs/foreign-subscribers.md gives for it — the node: ROS 2's default QoS and
// config/fastdds/ros2_subscriber_loopback.xml (4 MB socket buffers on 127.0.0.1); the rig: its cloud
// writers keep 1 s of history (depth 10) — it must get every scan from its first, whole, in order,
// none missing, and nothing else. (On Fast DDS's 208 kB default the node lives on repairs, falls up
// to ~1 s behind on this 2-core host and loses scans; with the writers' keep-last 2 a repair that
// outlasts 200 ms meets the Fast DDS defect of the last test: phantom samples, or Debian's abort.)
constexpr int kForeignReadersDepth = 10;

TEST(FastDdsInterop, OneNodeReadsEveryCloudOfThePhaseLockedRig) {
  const Paths where = paths();
  ASSERT_TRUE(where.problem.empty()) << where.problem;
  std::string why;
  const auto front = mock_rig_front(where.source, why);
  ASSERT_TRUE(front) << why;
  FastDdsShmGuard shm;
  const int domain = sensor_rig::test::lease_dds_domain();
  const char* depth_env = std::getenv("RIG_INTEROP_RIG_DEPTH");
  const std::string qos =
      "{reliability: reliable, depth: " +
      (depth_env != nullptr && *depth_env != '\0' ? std::string(depth_env) : std::to_string(kForeignReadersDepth)) +
      "}";
  std::string yaml = "rig:\n  name: interop\n  dds: {domain: " + std::to_string(domain) +
                     ", profile: " + front->profile + "}\nlidars:\n";
  const char* lidars[][3] = {{"front", "VLP-32C", "0"}, {"left", "OS-LEGACY", "90"}, {"right", "Pandar40P", "-90"}};
  for (const auto& l : lidars)
    yaml += std::string("  - {name: ") + l[0] + ", model: " + l[1] +
            ", port: " + std::to_string(test::free_udp_port()) + ", time_source: sensor, qos: " + qos +
            ", extrinsics: {yaw_deg: " + l[2] + "}, mock: {kind: synthetic, rpm: 600, phase_deg: 0}}\n";
  yaml += "fusion: {enable: true, frame_id: base_link, qos: " + qos + "}\n";
  test::TempDir dir;
  const std::string config = dir.write("rig.yaml", yaml);
  ::setenv("RIG_LOG_DIR", dir.path.c_str(), 1);  // the synthetic Ouster's metadata
  ChildProcess rig({where.rig, "up", config, "--duration", "300"});
  ::unsetenv("RIG_LOG_DIR");

  const int scans = scan_count();
  FastDdsNode::Options o;
  for (const char* t : {"front", "left", "right", "fused"})
    o.topics.push_back(std::string("rt/sensors/lidar/") + t + "/points");
  o.domain = domain;
  o.count = scans;
  o.timeout_s = o.count / 10 + 20;
  const char* profile_env = std::getenv("RIG_INTEROP_RIG_PROFILE");
  o.profile =
      profile_env != nullptr ? profile_env : (where.source / "config/fastdds/ros2_subscriber_loopback.xml").string();
  NodeResult r;
  {
    FastDdsNode node(where, o);
    EXPECT_TRUE(node.wait_matched(kWaitS * 1000)) << "the node's readers matched no writer in " << kWaitS << " s";
    r = node.finish((kWaitS + o.timeout_s + 10) * 1000);
  }
  EXPECT_EQ(rig.stop(), 0);
  ASSERT_EQ(r.topics.size(), 4u) << "one summary per topic (" << describe(r.exit) << ") " << r.stderr_hint;
  EXPECT_TRUE(r.exit.exited && r.exit.exit_code == 0) << describe(r.exit) << " " << r.stderr_hint;
  for (const auto& j : r.topics) {
    ASSERT_FALSE(j.is_discarded());
    const std::string topic = j["topic"].get<std::string>();
    std::vector<std::int64_t> stamps;
    for (const auto& s : j["stamps"]) stamps.push_back(s.get<std::int64_t>());
    std::cout << topic << ": " << j["whole"] << " whole, " << j["broken"] << " broken, " << j["phantom"] << " phantom, "
              << j["lost_reported"] << " reported lost, slowest " << j["max_delay_ms"] << " ms after its stamp\n";
    EXPECT_EQ(j["udp_receive_buffer"].get<std::uint32_t>(), o.profile.empty() ? 0u : 4u << 20) << topic;
    EXPECT_GE(j["whole"].get<int>(), o.count) << topic;
    EXPECT_EQ(j["broken"].get<int>(), 0) << topic;
    EXPECT_EQ(j["phantom"].get<int>(), 0) << topic;
    ASSERT_GE(stamps.size(), static_cast<std::size_t>(o.count)) << topic;
    // In order and none missing since the first: one 100 ms sweep apart.
    for (std::size_t i = 1; i < stamps.size(); ++i) {
      EXPECT_GT(stamps[i] - stamps[i - 1], 50'000'000) << topic << " scan " << i;
      EXPECT_LT(stamps[i] - stamps[i - 1], 150'000'000) << topic << " scan " << i << ": a scan missing";
    }
  }
}

// --- The defect, made to happen: RTPS submessages as the writer would send them -----------------

std::vector<std::uint8_t> from_hex(const std::string& h) {
  std::vector<std::uint8_t> b;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2)
    b.push_back(static_cast<std::uint8_t>(std::stoi(h.substr(i, 2), nullptr, 16)));
  return b;
}

// One RTPS message (little-endian submessages), from a writer's participant to one reader.
class RtpsMessage {
 public:
  RtpsMessage(const std::vector<std::uint8_t>& writer_guid, const std::vector<std::uint8_t>& reader_guid)
      : writer_id_(writer_guid.begin() + 12, writer_guid.end()),
        reader_id_(reader_guid.begin() + 12, reader_guid.end()) {
    bytes({'R', 'T', 'P', 'S', 2, 1, 0x01, 0x10});  // RTPS 2.1, vendor: Cyclone DDS (the writer's)
    bytes({writer_guid.begin(), writer_guid.begin() + 12});
    submessage(0x0e, 0x01, 12);  // INFO_DST
    bytes({reader_guid.begin(), reader_guid.begin() + 12});
  }
  void info_ts(std::int64_t ns) {
    submessage(0x09, 0x01, 8);
    u32(static_cast<std::uint32_t>(ns / 1'000'000'000));
    u32(static_cast<std::uint32_t>(((ns % 1'000'000'000) << 32) / 1'000'000'000));
  }
  // DATA_FRAG: fragments [first, first + n) of a sample of sample_size bytes.
  void data_frag(std::int64_t seq, std::uint32_t first, std::uint16_t fragment_size, std::uint32_t sample_size,
                 const std::vector<std::uint8_t>& fragment) {
    submessage(0x16, 0x01, 32 + fragment.size());
    u16(0);
    u16(28);  // octetsToInlineQos
    ids();
    sn(seq);
    u32(first);
    u16(1);
    u16(fragment_size);
    u32(sample_size);
    bytes(fragment);
  }
  void data(std::int64_t seq, const std::vector<std::uint8_t>& payload) {
    submessage(0x15, 0x01 | 0x04, 20 + payload.size());
    u16(0);
    u16(16);
    ids();
    sn(seq);
    bytes(payload);
  }
  // HEARTBEAT: the writer has first..last (final: no answer needed).
  void heartbeat(std::int64_t first, std::int64_t last, std::uint32_t count) {
    submessage(0x07, 0x01 | 0x02, 28);
    ids();
    sn(first);
    sn(last);
    u32(count);
  }
  // GAP: [start, base) irrelevant, no bitmap.
  void gap(std::int64_t start, std::int64_t base) {
    submessage(0x08, 0x01, 28);
    ids();
    sn(start);
    sn(base);
    u32(0);
  }
  [[nodiscard]] const std::vector<std::uint8_t>& wire() const { return b_; }

 private:
  void submessage(std::uint8_t id, std::uint8_t flags, std::size_t length) {
    b_.push_back(id);
    b_.push_back(flags);
    u16(static_cast<std::uint16_t>(length));
  }
  void ids() {
    bytes(reader_id_);
    bytes(writer_id_);
  }
  void sn(std::int64_t s) {
    u32(static_cast<std::uint32_t>(s >> 32));
    u32(static_cast<std::uint32_t>(s & 0xffffffff));
  }
  void u16(std::uint16_t v) {
    b_.push_back(static_cast<std::uint8_t>(v));
    b_.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) b_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void bytes(const std::vector<std::uint8_t>& v) { b_.insert(b_.end(), v.begin(), v.end()); }
  std::vector<std::uint8_t> writer_id_, reader_id_;
  std::vector<std::uint8_t> b_;
};

// A small, whole PointCloud2 (XCDR1, little-endian, encapsulation header first): 2 points, no fields.
std::vector<std::uint8_t> small_cloud(std::int64_t stamp_ns) {
  std::vector<std::uint8_t> b = {0x00, 0x01, 0x00, 0x00};
  const auto u32 = [&b](std::uint32_t v) {
    while ((b.size() - 4) % 4 != 0) b.push_back(0);
    for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  u32(static_cast<std::uint32_t>(stamp_ns / 1'000'000'000));
  u32(static_cast<std::uint32_t>(stamp_ns % 1'000'000'000));
  u32(4);  // frame_id "inj" + NUL
  b.insert(b.end(), {'i', 'n', 'j', 0});
  u32(1);          // height
  u32(2);          // width
  u32(0);          // no fields
  b.push_back(0);  // is_bigendian
  u32(4);          // point_step
  u32(8);          // row_step
  u32(8);          // data
  b.insert(b.end(), 8, 0x5a);
  b.push_back(1);  // is_dense
  while (b.size() % 4 != 0) b.push_back(0);
  return b;
}

// What the rig's writer does to a reader that falls behind, without the timing: the reader has the
// second half of a fragmented sample 1 and all of sample 2 when the writer, whose keep-last history
// no longer holds sample 1, answers the reader's repair request with GAP(1). A correct reader then
// delivers sample 2 and nothing else. Fast DDS 2.9 removes the half-assembled sample 1 with
// History::remove_change_nts (StatefulReader::processGapMsg), which returns it to the reader's pool
// but leaves it in the DataReaderHistory instance of a keyless type (every ROS 2 type): the node
// takes it as a valid sample no writer sent (writer GUID unknown, sequence number 0, empty payload)
// — the "broken" clouds, and Debian's build's aborts (DataReaderHistory.cpp:482,
// DataReaderInstance.hpp:105), of a node on Fast DDS's defaults reading the phase-locked rig on a
// loaded host. The same without the GAP (the writer's heartbeat says sample 1 is gone) is handled
// right: that path removes the sample from the instance too. docs/foreign-subscribers.md.
enum class Gone { kGap, kHeartbeat };

struct InjectedRun {
  NodeResult result;
  std::int64_t stamp = 0;  // sample 2's
};

void run_injected(const Paths& where, const RigWriterConfig& rig, Gone how, InjectedRun& out) {
  const int domain = 150 + static_cast<int>((::getpid() + 15) % 60);
  const std::string ros_topic =
      "/sensors/lidar/gap_" + std::to_string(::getpid()) + (how == Gone::kGap ? "_gap" : "_heartbeat") + "/points";
  // A writer that writes nothing: discovery and matching only; the data is ours.
  dds::Participant p(dds::DomainConfig{static_cast<dds_domainid_t>(domain), rig.profile});
  dds::Topic<msg::PointCloud2> topic(p, ros_topic, rig.lidar.qos);
  dds::Writer<msg::PointCloud2> writer(p, topic, rig.lidar.qos);

  FastDdsNode::Options o;
  o.topics = {dds::ros_to_dds_topic(ros_topic)};
  o.domain = domain;
  o.count = 2;  // never reached: it reports once nothing came for quiet_ms
  o.quiet_ms = 1500;
  FastDdsNode node(where, o);
  ASSERT_TRUE(node.wait_matched(kWaitS * 1000)) << "the Fast DDS reader matched no writer in " << kWaitS << " s";
  const Endpoints e = node.endpoints().front();
  ASSERT_EQ(e.writer_guid.size(), 32u);
  ASSERT_EQ(e.reader_guid.size(), 32u);
  ASSERT_GT(e.udp_port, 0);

  // One datagram: the receive thread handles its submessages in order, with nothing in between.
  out.stamp = vehicle_now_ns();
  RtpsMessage m(from_hex(e.writer_guid), from_hex(e.reader_guid));
  m.info_ts(out.stamp);
  constexpr std::uint16_t kFragment = 32768;
  m.data_frag(1, 2, kFragment, 2 * kFragment, std::vector<std::uint8_t>(kFragment, 0xa5));  // 2nd half of 1
  m.data(2, small_cloud(out.stamp));                                                        // all of 2
  if (how == Gone::kGap)
    m.gap(1, 2);  // 1 is gone: the answer to a repair request for it
  else
    m.heartbeat(2, 2, 1u << 30);  // the writer has 2..2: 1 is gone (a count above any it sent)
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(e.udp_port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const auto sent =
      ::sendto(fd, m.wire().data(), m.wire().size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  ::close(fd);
  ASSERT_EQ(sent, static_cast<ssize_t>(m.wire().size()));
  out.result = node.finish((kWaitS + 10) * 1000);
}

TEST(FastDdsInterop, AGapForAHalfReassembledSampleMakesFastDdsHandOutAPhantom) {
  const Paths where = paths();
  ASSERT_TRUE(where.problem.empty()) << where.problem;
  std::string why;
  const auto rig = mock_rig_front(where.source, why);
  ASSERT_TRUE(rig) << why;
  FastDdsShmGuard shm;
  for (const Gone how : {Gone::kHeartbeat, Gone::kGap}) {
    const char* name = how == Gone::kGap ? "GAP(1)" : "HEARTBEAT(2..2)";
    InjectedRun run;
    ASSERT_NO_FATAL_FAILURE(run_injected(where, *rig, how, run));
    const NodeResult& r = run.result;
    if (how == Gone::kGap && r.exit.term_signal == SIGABRT) {  // the defect too: Debian's build asserts
      std::cout << name << ": Fast DDS aborted on the dangling sample (its assertion is above)\n";
      continue;
    }
    ASSERT_EQ(r.topics.size(), 1u) << name << ": no summary (" << describe(r.exit) << ") " << r.stderr_hint;
    const nlohmann::json& j = r.topics.front();
    std::cout << "sample 1 half in, sample 2 whole, then " << name << ": " << j["received"] << " from the writer ("
              << j["whole"] << " whole, " << j["broken"] << " broken), " << j["phantom"] << " phantom ("
              << j["phantom_bytes"] << " bytes), " << j["lost_reported"] << " reported lost\n";
    std::set<std::int64_t> stamps;
    for (const auto& s : j["stamps"]) stamps.insert(s.get<std::int64_t>());
    EXPECT_EQ(j["whole"].get<int>(), 1) << name << ": sample 2";
    EXPECT_EQ(stamps.count(run.stamp), 1u) << name << ": sample 2";
    if (how == Gone::kHeartbeat) {
      EXPECT_EQ(j["received"].get<int>(), 1) << name << ": sample 2 and nothing else";
      EXPECT_EQ(j["phantom"].get<int>(), 0) << name;
    } else {
      EXPECT_GE(j["phantom"].get<int>(), 1)
          << name
          << ": Fast DDS handed out no phantom sample — the defect is gone from this Fast DDS version: "
             "update docs/foreign-subscribers.md and this test, which documents it";
      EXPECT_EQ(j["phantom_bytes"].get<int>(), 0) << name << ": the phantom's payload (released with its change)";
      EXPECT_EQ(j["received"].get<int>(), 1) << name << ": sample 2, and the phantom besides";
    }
  }
}

}  // namespace
}  // namespace sensor_rig
