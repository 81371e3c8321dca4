// ROS 2 nodes with rmw_fastrtps receive every LIDAR scan the rig writes, whole.
// The writer is what the rig's LIDAR node makes for config/mock_rig.yaml's front LIDAR (its QoS,
// the rig's Cyclone profile, 1.2 MB PointCloud2 at 10 Hz); the readers are Fast DDS processes
// (fastdds_pointcloud_sub), at once:
// - ROS 2's default QoS (reliable, keep-last 10) on Fast DDS's default participant (OS socket
//   buffers, 208 kB): it loses most of each burst and lives on repairs (config/cyclonedds/loopback.xml);
// - ROS 2's sensor-data QoS (best effort, keep-last 5) with config/fastdds/ros2_subscriber.xml: a
//   best-effort reader gets no repair, so only its own socket buffer keeps the scan (dds/README.md).
// And one such node reading the four clouds of a running, phase-locked rig at once.
// Measuring: RIG_INTEROP_SCANS=200 for longer runs; RIG_INTEROP_BE_PROFILE= (empty) runs the
// best-effort reader on Fast DDS's defaults too (it then loses most scans: what the profile is for).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_config.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "rig_process.hpp"
#include "test_data.hpp"

namespace sensor_rig {
namespace {

// 4 s at 10 Hz, or RIG_INTEROP_SCANS.
int scan_count() {
  const char* n = std::getenv("RIG_INTEROP_SCANS");
  return n != nullptr && *n != '\0' ? std::atoi(n) : 40;
}
constexpr int kPoints = 51460;      // the mock VLP-32C's scan: 1.2 MB
constexpr auto kPeriod = std::chrono::milliseconds(100);

// The front LIDAR of the mock rig: its writer QoS and the rig's Cyclone profile, as `rig up` reads them.
struct RigWriterConfig {
  drivers::LidarConfig lidar;
  std::string profile;
};

RigWriterConfig mock_rig_front() {
  auto problems = std::make_shared<config::Problems>();
  const auto root = config::Node::load_file((test::source_dir() / "config/mock_rig.yaml").string(), problems);
  RigWriterConfig c;
  c.profile = root.child("rig", true)->child("dds", true)->get_path("profile");
  c.lidar = drivers::parse_lidar_config(root.items("lidars", true).at(0));
  EXPECT_TRUE(problems->empty());
  return c;
}

struct ClientResult {
  int exit_status = -1;
  nlohmann::json summary;
};

class FastDdsClient {
 public:
  // profile: a Fast DDS XML file for FASTRTPS_DEFAULT_PROFILES_FILE; empty: Fast DDS's defaults.
  FastDdsClient(const std::string& topic, int domain, const std::string& qos, int scans,
                const std::string& profile = "") {
    ChildOptions o;
    o.pipe_stdio = true;
    o.env.push_back("SKIP_DEFAULT_XML=1");  // no DEFAULT_FASTRTPS_PROFILES.xml from the working directory
    if (profile.empty())
      ::unsetenv("FASTRTPS_DEFAULT_PROFILES_FILE");  // ours, not the caller's: Fast DDS's defaults
    else
      o.env.push_back("FASTRTPS_DEFAULT_PROFILES_FILE=" + profile);
    child_ = ChildProcess({FASTDDS_POINTCLOUD_SUB, "--topic", topic, "--domain", std::to_string(domain), "--qos", qos,
                           "--count", std::to_string(scans), "--timeout-s", std::to_string(scans / 10 + 15),
                           "--quiet-ms", "3000"},
                          o);
  }
  // True once its reader matched a writer (Fast DDS drops data of writers it has not matched).
  bool matched(int timeout_ms) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!matched_ && std::chrono::steady_clock::now() < deadline) {
      for (const auto& l : child_.read_lines()) matched_ = matched_ || l == "matched";
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return matched_;
  }
  ClientResult finish(int timeout_ms) {
    ClientResult r;
    std::string last;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!child_.stdout_eof() && std::chrono::steady_clock::now() < deadline) {
      for (auto& l : child_.read_lines()) last = l;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    child_.wait_exit(2000);
    r.exit_status = child_.stop();
    r.summary = nlohmann::json::parse(last, nullptr, false);
    return r;
  }

 private:
  ChildProcess child_;
  bool matched_ = false;
};

// udp_buffer: the receive buffer its Fast DDS profile asks for (0: the OS default, no profile).
void expect_every_scan(const ClientResult& r, const std::set<std::int64_t>& sent, const char* reader,
                       std::uint32_t udp_buffer) {
  const int scans = static_cast<int>(sent.size());
  ASSERT_FALSE(r.summary.is_discarded()) << reader << ": no summary";
  EXPECT_EQ(r.summary["udp_receive_buffer"].get<std::uint32_t>(), udp_buffer) << reader;
  std::cout << reader << ": " << r.summary["whole"] << " of " << sent.size() << " scans whole, "
            << r.summary["broken"] << " broken, " << r.summary["lost_reported"] << " reported lost, slowest "
            << r.summary["max_delay_ms"] << " ms after its stamp\n";
  std::set<std::int64_t> got;
  for (const auto& s : r.summary["stamps"]) got.insert(s.get<std::int64_t>());
  EXPECT_EQ(got, sent) << reader;
  EXPECT_EQ(r.summary["whole"].get<int>(), scans) << reader;
  EXPECT_EQ(r.summary["broken"].get<int>(), 0) << reader;
  EXPECT_EQ(r.exit_status, 0) << reader;
}

TEST(FastDdsInterop, DefaultRos2SubscribersReceiveEveryScan) {
  const RigWriterConfig rig = mock_rig_front();
  const int domain = 150 + static_cast<int>(::getpid() % 60);  // private to this run
  const std::string ros_topic = "/sensors/lidar/interop_" + std::to_string(::getpid()) + "/points";
  dds::Participant p(dds::DomainConfig{static_cast<dds_domainid_t>(domain), rig.profile});
  dds::Topic<msg::PointCloud2> topic(p, ros_topic, rig.lidar.qos);
  dds::Writer<msg::PointCloud2> writer(p, topic, rig.lidar.qos);

  const int scans = scan_count();
  FastDdsClient reliable(dds::ros_to_dds_topic(ros_topic), domain, "default", scans);
  const char* be_env = std::getenv("RIG_INTEROP_BE_PROFILE");
  const std::string be_profile =
      be_env != nullptr ? be_env : (test::source_dir() / "config/fastdds/ros2_subscriber.xml").string();
  FastDdsClient best_effort(dds::ros_to_dds_topic(ros_topic), domain, "sensor_data", scans, be_profile);
  ASSERT_TRUE(writer.wait_for_readers(2, 10000)) << "the Fast DDS readers were not discovered";
  ASSERT_TRUE(reliable.matched(5000));
  ASSERT_TRUE(best_effort.matched(5000));

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
  auto next = std::chrono::steady_clock::now();
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
  expect_every_scan(reliable.finish(15000), sent, "reliable keep-last 10 (ROS 2 default)", 0);
  expect_every_scan(best_effort.finish(15000), sent, "best effort keep-last 5 (ROS 2 sensor data)",
                    be_profile.empty() ? 0 : 4u << 20);
}

// One ROS 2 node with rmw_fastrtps defaults subscribed to all four clouds of a running rig whose
// three LIDARs are phase-locked: their scans (1.2, 0.5 and 1.5 MB) and then the 3.2 MB fused cloud
// all arrive within ~5 ms into one participant's 208 kB socket. It lives on repairs and must still
// get every scan, whole, in order, with no gap.
TEST(FastDdsInterop, OneDefaultNodeReadsEveryCloudOfThePhaseLockedRig) {
  const RigWriterConfig front = mock_rig_front();
  const int domain = 150 + static_cast<int>((::getpid() + 30) % 60);
  std::string yaml = "rig:\n  name: interop\n  dds: {domain: " + std::to_string(domain) + ", profile: " +
                     (test::source_dir() / "config" / front.profile).string() + "}\nlidars:\n";
  const char* lidars[][3] = {{"front", "VLP-32C", "0"}, {"left", "OS-LEGACY", "90"}, {"right", "Pandar40P", "-90"}};
  for (const auto& l : lidars)
    yaml += std::string("  - {name: ") + l[0] + ", model: " + l[1] + ", port: " + std::to_string(test::free_udp_port()) +
            ", time_source: sensor, qos: {reliability: reliable, depth: 2}, extrinsics: {yaw_deg: " + l[2] +
            "}, mock: {kind: synthetic, rpm: 600, phase_deg: 0}}\n";
  yaml += "fusion: {enable: true, frame_id: base_link}\n";
  test::TempDir dir;
  const std::string config = dir.write("rig.yaml", yaml);
  ::setenv("RIG_LOG_DIR", dir.path.c_str(), 1);  // the synthetic Ouster's metadata
  ChildProcess rig({test::rig_bin(), "up", config, "--duration", "40"});
  ::unsetenv("RIG_LOG_DIR");

  const int scans = scan_count();
  std::vector<std::string> argv = {FASTDDS_POINTCLOUD_SUB, "--domain", std::to_string(domain), "--count",
                                   std::to_string(scans), "--timeout-s", "25"};
  const char* topics[] = {"front", "left", "right", "fused"};
  for (const char* t : topics) argv.insert(argv.end(), {"--topic", std::string("rt/sensors/lidar/") + t + "/points"});
  ChildOptions o;
  o.pipe_stdio = true;
  o.env.push_back("SKIP_DEFAULT_XML=1");  // Fast DDS's defaults, as a ROS 2 node has them
  ::unsetenv("FASTRTPS_DEFAULT_PROFILES_FILE");
  ChildProcess node(argv, o);
  std::vector<nlohmann::json> lines;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(40);
  while (!node.stdout_eof() && std::chrono::steady_clock::now() < deadline) {
    for (const auto& l : node.read_lines())
      if (!l.empty() && l.front() == '{') lines.push_back(nlohmann::json::parse(l, nullptr, false));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  node.wait_exit(2000);
  EXPECT_EQ(node.stop(), 0);
  EXPECT_EQ(rig.stop(), 0);
  ASSERT_EQ(lines.size(), 4u) << "one summary per topic";
  for (const auto& j : lines) {
    ASSERT_FALSE(j.is_discarded());
    const std::string topic = j["topic"].get<std::string>();
    std::vector<std::int64_t> stamps;
    for (const auto& s : j["stamps"]) stamps.push_back(s.get<std::int64_t>());
    std::cout << topic << ": " << j["whole"] << " whole, " << j["broken"] << " broken, slowest " << j["max_delay_ms"]
              << " ms after its stamp\n";
    EXPECT_GE(j["whole"].get<int>(), scans) << topic;
    EXPECT_EQ(j["broken"].get<int>(), 0) << topic;
    // In order and none missing since the first: one 100 ms sweep apart.
    for (std::size_t i = 1; i < stamps.size(); ++i) {
      EXPECT_GT(stamps[i] - stamps[i - 1], 50'000'000) << topic << " scan " << i;
      EXPECT_LT(stamps[i] - stamps[i - 1], 150'000'000) << topic << " scan " << i << ": a scan missing";
    }
  }
}

}  // namespace
}  // namespace sensor_rig
