// End to end with real processes: `rig lidar replay` (UDP on loopback) -> `rig up` (driver) ->
// Cyclone DDS -> this process. Exactly the scans `rig lidar decode` finds in the same capture
// arrive, with the same point counts, and stamps that increase.
#include <gtest/gtest.h>

#include <arpa/inet.h>

#include <nlohmann/json.hpp>
#include <algorithm>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/dds/types.hpp"
#include "rig_process.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig {
namespace {

using test::rig_bin;

std::string rig_config(int port, const std::string& name, const std::string& model, const std::string& extra = "") {
  std::ostringstream y;
  y << "rig:\n  name: e2e\n  dds: {domain: 17, profile: " << test::source_dir().string() << "/config/cyclonedds/loopback.xml}\n"
    << "lidars:\n  - name: " << name << "\n    model: " << model << "\n    port: " << port
    << "\n    time_source: sensor\n    min_range: 0.0\n    max_range: 1000\n    qos: {reliability: reliable, depth: 100}\n"
    << extra;
  return y.str();
}

// A lidar name of this process only: a test run in another build dir on the same machine (same
// DDS domain, same loopback) publishes the same captures on its own topics, not on ours.
std::string unique(const std::string& name) { return name + "_" + std::to_string(::getpid()); }

struct Received {
  std::vector<std::size_t> points;
  std::vector<Nanos> stamps;
};

// Subscribes to `topic` until `quiet_ms` pass without a sample (after the first) or timeout.
Received receive_scans(dds::Reader<msg::PointCloud2>& reader, int quiet_ms, int timeout_ms) {
  Received r;
  const Nanos deadline = monotonic_now_ns() + Nanos{timeout_ms} * 1'000'000;
  Nanos last = monotonic_now_ns();
  while (monotonic_now_ns() < deadline) {
    if (reader.wait(100)) {
      reader.take([&](const msg::PointCloud2& pc, const dds_sample_info_t&) {
        r.points.push_back(pc.width);
        r.stamps.push_back(msg::from_time(pc.header.stamp));
        EXPECT_EQ(pc.point_step, 24u);
        EXPECT_EQ(pc.data._length, pc.width * 24u);
        EXPECT_EQ(pc.fields._length, 7u);
      });
      last = monotonic_now_ns();
    } else if (!r.points.empty() && monotonic_now_ns() - last > Nanos{quiet_ms} * 1'000'000) {
      break;
    }
  }
  return r;
}

struct Capture {
  const char* file;      // below $RIG_TEST_DATA/lidar
  const char* model;
  std::size_t min_scans;
  const char* metadata;  // below $RIG_TEST_DATA/lidar, or empty
};

class CaptureReplay : public ::testing::TestWithParam<Capture> {};

TEST_P(CaptureReplay, ArrivesScanByScanOverDds) {
  const auto c = GetParam();
  const auto pcap = test::test_data() / "lidar" / c.file;
  if (!std::filesystem::exists(pcap)) GTEST_SKIP() << "capture not found: " << pcap << " (set RIG_TEST_DATA)";
  test::TempDir dir;

  // What the offline decoder finds in the capture: the reference point counts.
  const std::string metadata = *c.metadata ? (test::test_data() / "lidar" / c.metadata).string() : "";
  const auto [rc, out] = test::run(rig_bin() + " lidar decode --pcap " + pcap.string() + " --model " + c.model +
                                   (metadata.empty() ? "" : " --metadata " + metadata) +
                                   " --min-range 0 --max-range 1000 --out " + (dir.path / "pcd").string());
  ASSERT_EQ(rc, 0) << out;
  std::vector<std::size_t> expected;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (!line.empty()) expected.push_back(nlohmann::json::parse(line)["points"].get<std::size_t>());
  ASSERT_GE(expected.size(), c.min_scans);

  const int port = test::free_udp_port();
  const auto cfg =
      dir.write("rig.yaml", rig_config(port, unique("e2e"), c.model, metadata.empty() ? "" : "    metadata: " + metadata + "\n"));
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "60"});

  dds::Participant p({17, test::source_dir().string() + "/config/cyclonedds/loopback.xml"});
  dds::QosSpec q;
  q.depth = 100;
  dds::Topic<msg::PointCloud2> topic(p, "/sensors/lidar/" + unique("e2e") + "/points", q);
  dds::Reader<msg::PointCloud2> reader(p, topic, q);
  ASSERT_TRUE(reader.wait_for_writers(1, test::kDiscoveryMs)) << "driver did not come up";
  // The driver's writer learns of this reader a moment after we saw it (discovery is per side);
  // a volatile scan written before that would never reach us. The first scan is >= 100 ms into
  // the capture anyway; this margin covers slow (sanitizer) builds.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  ChildProcess replay({rig_bin(), "lidar", "replay", "--pcap", pcap.string(), "--to", "127.0.0.1:" + std::to_string(port)});
  const auto got = receive_scans(reader, 1500, 30000);
  replay.stop();
  EXPECT_EQ(rig.stop(), 0);

  // The offline decoder and the driver both emit complete scans only (the partial scan before the
  // first cut and the one the capture ends in are dropped by both), and the driver was listening
  // before the first packet was sent: both see the same packets in the same order, so the scan
  // sequences are identical — no scan missing at either end, none extra, same point counts.
  EXPECT_EQ(got.points, expected);
  for (std::size_t i = 1; i < got.stamps.size(); ++i) EXPECT_GT(got.stamps[i], got.stamps[i - 1]) << "scan " << i;
}

INSTANTIATE_TEST_SUITE_P(
    Captures, CaptureReplay,
    ::testing::Values(Capture{"velodyne/vlp16_veloview_vlp-16-test-90deg-1-50-frames.pcap", "VLP-16", 40, ""},
                      Capture{"hesai/pandar40p_nebula_1673400149412331409.pcap", "Pandar40P", 2, ""},
                      Capture{"ouster/OS-1-32-G_v2.1.1_1024x10.pcap", "OS-LEGACY", 1,
                              "ouster/OS-1-32-G_v2.1.1_1024x10.json"}),
    [](const auto& param_info) {
      std::string n = param_info.param.model;
      n.erase(std::remove(n.begin(), n.end(), '-'), n.end());  // gtest names: alphanumerics only
      return n;
    });

TEST(LidarEndToEnd, SyntheticMockRigPublishesAllThreeModels) {
  test::TempDir dir;
  std::ostringstream y;
  y << "rig:\n  name: e2e-mock\n  dds: {domain: 18, profile: " << test::source_dir().string()
    << "/config/cyclonedds/loopback.xml}\nlidars:\n";
  const char* models[] = {"VLP-16", "VLP-32C", "HDL-32E"};
  for (int i = 0; i < 3; ++i)
    y << "  - {name: l" << i << ", model: " << models[i] << ", port: " << test::free_udp_port()
      << ", time_source: host, mock: {kind: synthetic, rpm: 600}}\n";
  const auto cfg = dir.write("rig.yaml", y.str());
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "30"});

  dds::Participant p({18, test::source_dir().string() + "/config/cyclonedds/loopback.xml"});
  std::vector<std::unique_ptr<dds::Topic<msg::PointCloud2>>> topics;
  std::vector<std::unique_ptr<dds::Reader<msg::PointCloud2>>> readers;
  dds::QosSpec q;
  q.depth = 50;
  for (int i = 0; i < 3; ++i) {
    topics.push_back(std::make_unique<dds::Topic<msg::PointCloud2>>(p, "/sensors/lidar/l" + std::to_string(i) + "/points", q));
    readers.push_back(std::make_unique<dds::Reader<msg::PointCloud2>>(p, *topics.back(), q));
  }
  dds::Topic<msg::DiagnosticArray> diag_topic(p, "/diagnostics");
  dds::Reader<msg::DiagnosticArray> diag(p, diag_topic);
  for (auto& r : readers) ASSERT_TRUE(r->wait_for_writers(1, test::kDiscoveryMs));
  // All three at once, as a fusion node would: no reader sits unread while another is drained.
  std::vector<Received> all(3);
  for (const Nanos end = monotonic_now_ns() + 2'500'000'000; monotonic_now_ns() < end;) {
    for (std::size_t i = 0; i < 3; ++i) {
      readers[i]->take([&](const msg::PointCloud2& pc, const dds_sample_info_t&) {
        all[i].points.push_back(pc.width);
        all[i].stamps.push_back(msg::from_time(pc.header.stamp));
      });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (int i = 0; i < 3; ++i) {
    const auto& got = all[static_cast<std::size_t>(i)];
    // 600 rpm = 10 Hz: 2.5 s of listening holds well over 10 scans of a plausible size.
    EXPECT_GE(got.points.size(), 10u) << models[i];
    for (auto n : got.points) EXPECT_GT(n, 1000u) << models[i];
    // Host stamps (time_source: host) carry the mock's and the driver's scheduling delays: on a
    // loaded 2-core machine a packet is sent or read up to ~30 ms late. Each interval is one
    // revolution give or take that (a missed scan would be 200 ms), and on average exactly one.
    for (std::size_t k = 1; k < got.stamps.size(); ++k) {
      const Nanos dt = got.stamps[k] - got.stamps[k - 1];
      EXPECT_GT(dt, 50'000'000) << models[i];
      EXPECT_LT(dt, 150'000'000) << models[i];
    }
    if (got.stamps.size() >= 2) {
      const double mean_dt = static_cast<double>(got.stamps.back() - got.stamps.front()) /
                             static_cast<double>(got.stamps.size() - 1);
      EXPECT_NEAR(mean_dt, 100e6, 5e6) << models[i];
    }
  }

  // Diagnostics: one status per driver, with its counters, as diagnostic_msgs/DiagnosticArray;
  // and the PU clock's rig/time (no linuxptp on a test host: a state, never a missing status).
  std::set<std::string> seen;
  std::string ptp_state;
  for (int tries = 0; tries < 30 && (seen.size() < 3 || ptp_state.empty()); ++tries) {
    diag.wait(200);
    diag.take([&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
      for (std::uint32_t k = 0; k < a.status._length; ++k) {
        const auto& st = a.status._buffer[k];
        std::map<std::string, std::string> kv;
        for (std::uint32_t v = 0; v < st.values._length; ++v) kv[st.values._buffer[v].key] = st.values._buffer[v].value;
        const std::string name = st.name;
        if (name == "rig/time") {
          ptp_state = kv["ptp_state"];
          EXPECT_TRUE(kv.contains("realtime_steps"));
          continue;
        }
        if (kv.contains("scans") && std::stoull(kv["scans"]) > 0 && st.level == 0) seen.insert(name);
        EXPECT_EQ(kv["packets_dropped"], "0") << name;
      }
    });
  }
  EXPECT_EQ(seen, (std::set<std::string>{"lidar/l0", "lidar/l1", "lidar/l2"}));
  EXPECT_FALSE(ptp_state.empty()) << "no rig/time status in /diagnostics";

  // The monitor, as a separate process: one JSON line per topic per second with every stage.
  const auto [rc, out] = test::run(rig_bin() + " monitor --json --duration 3.5 --domain 18 --dds-profile " +
                                   test::source_dir().string() + "/config/cyclonedds/loopback.xml");
  EXPECT_EQ(rc, 0);
  std::map<std::string, nlohmann::json> last;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    auto j = nlohmann::json::parse(line);
    last[j["topic"]] = j;
  }
  ASSERT_EQ(last.size(), 3u) << out;
  for (const auto& [topic, j] : last) {
    // 10 Hz sensors; a loaded 2-core CI machine may delay a window's samples into the next one.
    EXPECT_GT(j["rate_hz"].get<double>(), 3.0) << topic;
    EXPECT_LT(j["rate_hz"].get<double>(), 15.0) << topic;
    EXPECT_GT(j["received"].get<int>(), 15) << topic;
    EXPECT_EQ(j["lost"].get<int>(), 0) << topic;
    EXPECT_GT(j["size_bytes"].get<int>(), 24000) << topic;
    for (const char* stage : {"sensor", "process", "dds", "total"}) {
      ASSERT_TRUE(j["latency_ms"].contains(stage)) << topic << " " << stage;
      EXPECT_GE(j["latency_ms"][stage]["p50"].get<double>(), 0.0) << topic << " " << stage;
      EXPECT_LE(j["latency_ms"][stage]["p50"].get<double>(), j["latency_ms"][stage]["max"].get<double>());
    }
    // A scan's first firing is ~100 ms (one revolution at 600 rpm) before its last packet, and the
    // total covers the sensor stage. (How far above that it lies is a benchmark, not a test.)
    EXPECT_GT(j["latency_ms"]["total"]["p50"].get<double>(), 90.0) << topic;
    EXPECT_GE(j["latency_ms"]["total"]["max"].get<double>(), j["latency_ms"]["sensor"]["max"].get<double>()) << topic;
  }
  EXPECT_EQ(rig.stop(), 0);
}

// Velodyne-shaped garbage for the data port, one kind per drop reason the driver reports.
struct BadPackets {
  int wrong_size = 40;      // 100-byte datagrams
  int bad_block_flag = 30;  // 1206 zero bytes
  int bad_azimuth = 20;     // flags right, azimuth 400.00°
  int wrong_model = 10;     // a VLP-32C's product id at a VLP-16 driver
  [[nodiscard]] int total() const { return wrong_size + bad_block_flag + bad_azimuth + wrong_model; }
};

std::vector<std::uint8_t> velodyne_like(std::uint16_t azimuth, std::uint8_t product_id, std::uint32_t seed) {
  std::vector<std::uint8_t> p(1206);
  for (auto& b : p) b = static_cast<std::uint8_t>((seed = seed * 1103515245U + 12345U) >> 24);  // garbage ranges, time
  for (std::size_t blk = 0; blk < 12; ++blk) {
    p[blk * 100] = 0xFF;
    p[blk * 100 + 1] = 0xEE;
    p[blk * 100 + 2] = static_cast<std::uint8_t>(azimuth & 0xFF);
    p[blk * 100 + 3] = static_cast<std::uint8_t>(azimuth >> 8);
  }
  p[1204] = 0x37;  // strongest return
  p[1205] = product_id;
  return p;
}

// Sends the bad datagrams to 127.0.0.1:port, interleaved with whatever else arrives there.
void send_bad_packets(int port, const BadPackets& n) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  auto send = [&](const std::vector<std::uint8_t>& d) {
    EXPECT_EQ(::sendto(fd, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(d.size()));
    std::this_thread::sleep_for(std::chrono::microseconds(500));  // spread over ~50 ms of good packets
  };
  for (int i = 0; i < n.wrong_size; ++i) send(std::vector<std::uint8_t>(100, static_cast<std::uint8_t>(i)));
  for (int i = 0; i < n.bad_block_flag; ++i) send(std::vector<std::uint8_t>(1206, 0));
  for (int i = 0; i < n.bad_azimuth; ++i) send(velodyne_like(40000, 0x22, static_cast<std::uint32_t>(i)));
  for (int i = 0; i < n.wrong_model; ++i) send(velodyne_like(1000, 0x28, static_cast<std::uint32_t>(i + 100)));
  ::close(fd);
}

struct LidarStatus {
  int level = -1;
  std::string message;
  std::map<std::string, std::string> values;
};

// A sensor that stops sending: the driver keeps running and its diagnostics turn to ERROR with a
// message naming the silence; it recovers when packets come back. Garbage among the packets
// (wrong size, bad flags, bad azimuth, another model) is dropped and counted per reason while the
// scans keep coming.
TEST(LidarEndToEnd, DeadDeviceAndBadPacketsAreReportedInDiagnostics) {
  test::TempDir dir;
  const int port = test::free_udp_port();
  const auto cfg = dir.write("rig.yaml", rig_config(port, unique("dead"), "VLP-16"));
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "60"});
  dds::Participant p({17, test::source_dir().string() + "/config/cyclonedds/loopback.xml"});
  dds::Topic<msg::DiagnosticArray> topic(p, "/diagnostics");
  dds::Reader<msg::DiagnosticArray> diag(p, topic);
  ASSERT_TRUE(diag.wait_for_writers(1, test::kDiscoveryMs));

  // lidar/dead_<pid> in the next diagnostics sample.
  auto next_status = [&]() {
    LidarStatus r;
    for (int tries = 0; tries < 30 && r.level < 0; ++tries) {
      diag.wait(200);
      diag.take([&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
        for (std::uint32_t k = 0; k < a.status._length; ++k) {
          const auto& st = a.status._buffer[k];
          if (std::string(st.name) != "lidar/" + unique("dead")) continue;
          r.level = st.level;
          r.message = st.message;
          for (std::uint32_t v = 0; v < st.values._length; ++v) r.values[st.values._buffer[v].key] = st.values._buffer[v].value;
        }
      });
    }
    return r;
  };
  EXPECT_EQ(next_status().level, 1) << "WARN while no packet ever arrived";

  auto send = [&](const char* seconds) {
    return test::run(rig_bin() + " lidar replay --synthetic VLP-16 --to 127.0.0.1:" + std::to_string(port) +
                     " --duration " + seconds + " 2>/dev/null");
  };
  EXPECT_EQ(send("1.5").first, 0);
  // Right after the sensor went quiet the last status may still be OK; within ~2 s it is ERROR.
  LidarStatus st;
  for (int i = 0; i < 6 && st.level != 2; ++i) st = next_status();
  EXPECT_EQ(st.level, 2);
  EXPECT_NE(st.message.find("no scan for"), std::string::npos) << st.message;
  ASSERT_EQ(st.values.at("packets_dropped"), "0") << "a clean sensor drops nothing";

  // Packets again: back to OK while it sends, garbage and all.
  ChildProcess sender({rig_bin(), "lidar", "replay", "--synthetic", "VLP-16", "--to",
                       "127.0.0.1:" + std::to_string(port), "--duration", "5"});
  for (int i = 0; i < 8 && st.level != 0; ++i) st = next_status();
  EXPECT_EQ(st.level, 0) << st.message;
  const BadPackets bad;
  send_bad_packets(port, bad);
  const auto scans_after_garbage = std::stoull(next_status().values.at("scans"));
  for (int i = 0; i < 8; ++i) {
    st = next_status();
    if (std::stoull(st.values.at("scans")) >= scans_after_garbage + 10) break;
  }
  sender.stop();
  EXPECT_EQ(rig.stop(), 0);
  // Scans kept coming (10 Hz: a diagnostics period holds ~10) and the status stayed OK. But for one
  // thing that is not the garbage's: a sender held off its core (this suite under ctest -j2: the
  // replay reported sends up to 32 ms late, 2026-11-30) delivers packets later than their sensor
  // time, which the rig rightly flags (WARN, "packets arrive N ms later than the sensor's clock
  // says"); the garbage itself must leave the status as it was.
  EXPECT_GE(std::stoull(st.values.at("scans")), scans_after_garbage + 10);
  const bool late_sender = st.level == 1 && st.message.find("later than the sensor's clock says") != std::string::npos;
  EXPECT_TRUE(st.level == 0 || late_sender) << st.message;
  // Loopback with an 8 MB receive buffer loses nothing: every bad datagram is counted, by reason.
  EXPECT_EQ(st.values.at("kernel_drops"), "0");
  EXPECT_EQ(st.values["dropped_wrong_size"], std::to_string(bad.wrong_size));
  EXPECT_EQ(st.values["dropped_bad_block_flag"], std::to_string(bad.bad_block_flag));
  EXPECT_EQ(st.values["dropped_bad_azimuth"], std::to_string(bad.bad_azimuth));
  EXPECT_EQ(st.values["dropped_wrong_model"], std::to_string(bad.wrong_model));
  // The second sender is a sensor restarted with another clock: the first packet after its time jump
  // is judged alone (a single implausible time is a corrupt packet, issue 26) and dropped as bad_time,
  // counted, until the next one confirms the step. Whether it lands in this status depends on timing.
  const auto bad_time = st.values.count("dropped_bad_time") ? std::stoull(st.values.at("dropped_bad_time")) : 0ULL;
  EXPECT_LE(bad_time, 1ULL);
  EXPECT_EQ(st.values.at("packets_dropped"), std::to_string(bad.total() + bad_time));
}

}  // namespace
}  // namespace sensor_rig
