// `rig up` with rig.dds.transport: shm — real processes: `rig up` (its own iox-roudi, a synthetic
// VLP-16 and its driver), this test as a shared-memory subscriber, `rig monitor` over UDP as the
// "remote" one. Proof of the path: every cloud this process takes references an iceoryx chunk
// (Cyclone 0.10 serialises PointCloud2 into the chunk), the UDP monitor's none could.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dds_domain_lease.hpp"
#include "rig_process.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/dds/roudi.hpp"
#include "sensor_rig/dds/shared_memory.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/record/mcap_reader.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig {
namespace {

const dds_domainid_t kDomain = static_cast<dds_domainid_t>(sensor_rig::test::lease_dds_domain());

std::string rig_bin() { return std::getenv("RIG_BIN"); }
std::string source_dir() { return std::getenv("RIG_SOURCE_DIR"); }
std::string profile() { return source_dir() + "/config/cyclonedds/loopback.xml"; }

std::string rig_yaml(const std::string& transport, int port) {
  std::ostringstream y;
  y << "rig:\n  name: shm-test\n  dds: {domain: " << kDomain << ", profile: " << profile()
    << ", transport: " << transport << "}\n"
    << "lidars:\n  - name: front\n    model: VLP-16\n    port: " << port
    << "\n    position_port: 0\n    realtime_priority: 0\n    qos: {reliability: reliable, depth: 2}\n"
    << "    mock: {kind: synthetic, rpm: 600}\n";
  return y.str();
}

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

pid_t parent_of(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  const auto close = line.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream in(line.substr(close + 2));
  std::string state;
  pid_t ppid = 0;
  in >> state >> ppid;
  return ppid;
}

// The iox-roudi `rig up` (pid `rig`) started, once it answers; 0 after timeout_ms.
pid_t roudi_of(pid_t rig, int timeout_ms) {
  for (int waited = 0; waited < timeout_ms; waited += 20) {
    for (pid_t p : find_processes("iox-roudi"))
      if (parent_of(p) == rig && dds::probe_roudi().answers) return p;
    ::usleep(20'000);
  }
  return 0;
}

bool process_exists(pid_t pid) { return ::kill(pid, 0) == 0; }

// Runs fn in a forked process and returns the text it produced (empty if it died or hung 20 s).
std::string in_child_process(std::string (*fn)()) {
  int fds[2];
  if (::pipe(fds) != 0) return {};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const std::string out = fn() + "\n";
    (void)!::write(fds[1], out.data(), out.size());
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string out;
  char buf[256];
  for (int waited = 0; waited < 20000; waited += 10) {
    int st = 0;
    if (::waitpid(pid, &st, WNOHANG) == pid) break;
    ::usleep(10'000);
    if (waited + 10 >= 20000) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &st, 0);
    }
  }
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, static_cast<std::size_t>(n));
  ::close(fds[0]);
  return out;
}

class ShmRig : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::access("/usr/bin/iox-roudi", X_OK) != 0) GTEST_SKIP() << "no iox-roudi (Debian package iceoryx)";
    if (dds::probe_roudi().pid != 0) GTEST_SKIP() << "another RouDi runs on this machine; these tests need their own";
  }
  test::TempDir dir_;
  ChildOptions logged(const std::string& name) {
    ChildOptions o;
    o.log_file = (dir_.path / name).string();
    return o;
  }
};

TEST_F(ShmRig, LocalSubscriberGetsCloudsThroughSharedMemoryRemoteOneOverUdp) {
  const auto cfg = dir_.write("rig.yaml", rig_yaml("shm", test::free_udp_port()));
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "20"}, logged("rig.log"));
  const pid_t roudi = roudi_of(rig.pid(), 8000);
  ASSERT_NE(roudi, 0) << "rig up started no RouDi:\n" << read_all(dir_.path / "rig.log");

  // The "remote" subscriber: `rig monitor` without shared memory, so Cyclone must send it UDP.
  ChildOptions mon = logged("monitor.log");
  mon.pipe_stdio = true;
  ChildProcess monitor({rig_bin(), "monitor", "/sensors/lidar/front/points", "--json", "--duration", "4", "--domain",
                        std::to_string(kDomain), "--dds-profile", profile(), "--transport", "udp"},
                       mon);

  // The shared-memory subscriber is a process of its own that ends before the rig: stopping RouDi
  // SIGTERMs every process registered with it.
  const auto sub = in_child_process([] {
    dds::Participant p({kDomain, profile(), dds::Transport::kShm});
    dds::QosSpec q;
    q.depth = 4;
    dds::Topic<msg::PointCloud2> topic(p, "/sensors/lidar/front/points", q);
    dds::Reader<msg::PointCloud2> reader(p, topic, q);
    if (!dds::uses_shared_memory(reader.handle())) return std::string("no iceoryx subscriber");
    if (!reader.wait_for_writers(1, test::kDiscoveryMs)) return std::string("no writer");
    msg::PointCloud2 scratch{};
    dds::TakeCounts counts;
    std::uint64_t bytes = 0;
    for (const Nanos end = monotonic_now_ns() + 3'000'000'000; monotonic_now_ns() < end;) {
      reader.wait(100);
      dds::take_in_place(reader.handle(), scratch, counts, [&](const msg::PointCloud2& pc) { bytes += pc.data._length; });
    }
    sensor_msgs_msg_dds__PointCloud2__free(&scratch, DDS_FREE_CONTENTS);
    return std::to_string(counts.copied) + " " + std::to_string(counts.serialized_chunk) + " " +
           std::to_string(counts.zero_copy) + " " + std::to_string(bytes);
  });
  std::istringstream in(sub);
  std::uint64_t copied = 0, serialized_chunk = 0, zero_copy = 0, bytes = 0;
  ASSERT_TRUE(in >> copied >> serialized_chunk >> zero_copy >> bytes) << "subscriber: " << sub << "\n"
                                                                      << read_all(dir_.path / "rig.log");
  EXPECT_GE(copied, 20u) << "10 Hz for 3 s";
  EXPECT_EQ(serialized_chunk, copied) << "every cloud came in an iceoryx chunk, none over UDP";
  EXPECT_EQ(zero_copy, 0u) << "Cyclone 0.10 cannot loan PointCloud2 (strings, sequences)";
  EXPECT_GT(bytes / std::max<std::uint64_t>(copied, 1), 100'000u) << "whole clouds";

  // The UDP subscriber got them too.
  ASSERT_TRUE(monitor.wait_exit(8000));
  std::uint64_t monitor_received = 0;
  for (const auto& line : monitor.read_lines()) {
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_object() && j.value("topic", "") == "/sensors/lidar/front/points")
      monitor_received = std::max(monitor_received, j.value("received", std::uint64_t{0}));
  }
  EXPECT_GE(monitor_received, 10u) << read_all(dir_.path / "monitor.log");

  // A clean stop: RouDi gone, its shared memory and sockets removed.
  EXPECT_EQ(rig.stop(10000), 0) << read_all(dir_.path / "rig.log");
  EXPECT_FALSE(process_exists(roudi));
  EXPECT_FALSE(std::filesystem::exists("/dev/shm/iceoryx_mgmt"));
  EXPECT_FALSE(std::filesystem::exists("/tmp/roudi"));
}

// Each cloud of a recording, by its header stamp: FNV-1a of the point data, and whether it was whole
// (width x height x point_step bytes). Malformed messages count under stamp 0.
struct RecordedClouds {
  std::map<std::int64_t, std::uint32_t> fnv;
  std::uint64_t messages = 0, whole = 0;
};
RecordedClouds read_clouds(const std::string& file) {
  RecordedClouds out;
  record::McapReader r(file);
  dds::PointCloud2View v;
  r.for_each_message([&](const record::McapMessage& m) {
    ++out.messages;
    const auto body = dds::cdr_body(m.data);
    if (!body || dds::parse_cdr(*body, v) != dds::CdrStatus::kOk) return true;
    const std::int64_t stamp = std::int64_t{v.header.sec} * 1'000'000'000 + v.header.nanosec;
    std::uint32_t h = 0x811c9dc5u;
    for (const std::byte b : v.data) h = (h ^ static_cast<std::uint8_t>(b)) * 0x01000193u;
    out.fnv[stamp] = h;
    if (v.data.size() == std::size_t{v.width} * v.height * v.point_step && v.width > 1000) ++out.whole;
    return true;
  });
  return out;
}

// `rig record --transport shm` beside `rig record --transport udp`, both on the shared-memory rig:
// the same clouds, byte for byte (the shm recorder writes the CDR it takes from the iceoryx chunk,
// the udp one what came over the wire), every one whole, none dropped, and each recorder's count
// what it says it wrote.
TEST_F(ShmRig, RecordingOverSharedMemoryKeepsEveryCloudByteForByte) {
  const auto cfg = dir_.write("rig.yaml", rig_yaml("shm", test::free_udp_port()));
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "25"}, logged("rig.log"));
  ASSERT_NE(roudi_of(rig.pid(), 8000), 0) << "rig up started no RouDi:\n" << read_all(dir_.path / "rig.log");
  const auto recorder = [&](const std::string& transport) {
    ChildOptions o = logged("record_" + transport + ".log");
    o.pipe_stdio = true;
    return std::make_unique<ChildProcess>(
        std::vector<std::string>{rig_bin(), "record", "/sensors/lidar/front/points", "--out",
                                 (dir_.path / (transport + ".mcap")).string(), "--duration", "4", "--compression", "none",
                                 "--domain", std::to_string(kDomain), "--dds-profile", profile(), "--transport", transport},
        o);
  };
  auto shm = recorder("shm");
  auto udp = recorder("udp");
  std::map<std::string, nlohmann::json> summary;
  for (auto& [name, child] : {std::pair{std::string("shm"), shm.get()}, std::pair{std::string("udp"), udp.get()}}) {
    ASSERT_TRUE(child->wait_exit(test::kDiscoveryMs + 15000)) << name << ": " << read_all(dir_.path / ("record_" + name + ".log"));
    EXPECT_EQ(child->exit_status(), 0) << name << ": " << read_all(dir_.path / ("record_" + name + ".log"));
    for (const auto& line : child->read_lines()) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      if (j.is_object() && j.contains("topics")) summary[name] = j;
    }
    ASSERT_TRUE(summary.contains(name)) << name << ": no summary\n" << read_all(dir_.path / ("record_" + name + ".log"));
  }
  const auto shm_clouds = read_clouds((dir_.path / "shm.mcap").string());
  const auto udp_clouds = read_clouds((dir_.path / "udp.mcap").string());
  for (const auto& [name, c] : {std::pair{std::string("shm"), &shm_clouds}, std::pair{std::string("udp"), &udp_clouds}}) {
    const auto& t = summary[name]["topics"]["/sensors/lidar/front/points"];
    EXPECT_GE(c->messages, 20u) << name << ": 10 Hz for up to 4 s";
    EXPECT_EQ(c->whole, c->messages) << name << ": every cloud whole";
    EXPECT_EQ(t.value("written", 0u), c->messages) << name << ": " << summary[name].dump();
    // The shm recorder took every cloud from an iceoryx chunk, the udp one none.
    EXPECT_EQ(t.value("shared_memory", 99u), name == "shm" ? t.value("received", 0u) : 0u) << name << ": " << t.dump();
    EXPECT_EQ(summary[name]["drops"].value("dds_lost", 1u) + summary[name]["drops"].value("queue_full", 1u), 0u) << summary[name].dump();
  }
  std::size_t both = 0, equal = 0;
  for (const auto& [stamp, h] : shm_clouds.fnv) {
    const auto it = udp_clouds.fnv.find(stamp);
    if (it == udp_clouds.fnv.end()) continue;
    ++both;
    if (it->second == h) ++equal;
  }
  std::printf("recorded over shm %llu clouds, over udp %llu, %zu in both, %zu equal\n",
              static_cast<unsigned long long>(shm_clouds.messages), static_cast<unsigned long long>(udp_clouds.messages), both, equal);
  EXPECT_GE(both, 15u) << "the two recordings overlap for most of their 4 s";
  EXPECT_EQ(equal, both) << "a cloud recorded over shared memory differs from the same cloud over UDP";
  EXPECT_EQ(rig.stop(10000), 0) << read_all(dir_.path / "rig.log");
}

TEST_F(ShmRig, RoudiKilledMidRunIsReportedAndTheNextRunStartsClean) {
  const auto cfg = dir_.write("rig.yaml", rig_yaml("shm", test::free_udp_port()));
  ChildProcess rig({rig_bin(), "up", cfg, "--duration", "30"}, logged("rig.log"));
  const pid_t roudi = roudi_of(rig.pid(), 8000);
  ASSERT_NE(roudi, 0) << read_all(dir_.path / "rig.log");
  ::usleep(500'000);  // the driver is publishing
  ::kill(roudi, SIGKILL);  // a RouDi this test did not start, but the rig's child it found by parent pid
  ASSERT_TRUE(rig.wait_exit(8000)) << "rig up hung after RouDi died:\n" << read_all(dir_.path / "rig.log");
  EXPECT_EQ(rig.exit_status(), 1);
  const auto log = read_all(dir_.path / "rig.log");
  EXPECT_NE(log.find("shared memory transport lost: iox-roudi pid " + std::to_string(roudi) + " was killed by signal 9"),
            std::string::npos)
      << log;
  EXPECT_FALSE(std::filesystem::exists("/dev/shm/iceoryx_mgmt")) << "the killed RouDi's segments were removed";

  // rig up killed outright: its RouDi goes with it (parent-death signal), and a new run works.
  ChildProcess again({rig_bin(), "up", cfg, "--duration", "30"}, logged("rig2.log"));
  const pid_t roudi2 = roudi_of(again.pid(), 8000);
  ASSERT_NE(roudi2, 0) << read_all(dir_.path / "rig2.log");
  again.signal(SIGKILL);
  ASSERT_TRUE(again.wait_exit(2000));
  for (int i = 0; i < 100 && process_exists(roudi2); ++i) ::usleep(50'000);
  EXPECT_FALSE(process_exists(roudi2)) << "RouDi outlived the rig that started it";
  const auto [rc, out] = test::run(rig_bin() + " up " + cfg + " --duration 1 2>&1");
  EXPECT_EQ(rc, 0) << out;
}

TEST_F(ShmRig, ARunningRoudiIsJoinedAStoppedOneRefused) {
  ChildOptions o = logged("roudi.log");
  o.process_group = 0;
  ChildProcess roudi({"/usr/bin/iox-roudi", "-c", source_dir() + "/config/iceoryx/rig-roudi.toml"}, o);
  for (int i = 0; i < 400 && !dds::probe_roudi().answers; ++i) ::usleep(20'000);
  ASSERT_TRUE(dds::probe_roudi().answers) << read_all(dir_.path / "roudi.log");
  const auto cfg = dir_.write("rig.yaml", rig_yaml("shm", test::free_udp_port()));

  roudi.signal(SIGSTOP);  // a RouDi that is there but cannot answer: refused, not waited for 60 s
  const Nanos t0 = monotonic_now_ns();
  auto [rc, out] = test::run(rig_bin() + " up " + cfg + " --duration 2 2>&1");
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("is stopped"), std::string::npos) << out;
  EXPECT_LT(monotonic_now_ns() - t0, 5'000'000'000);
  roudi.signal(SIGCONT);

  std::tie(rc, out) = test::run(rig_bin() + " up " + cfg + " --duration 2 2>&1");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("using the RouDi already running (iox-roudi pid " + std::to_string(roudi.pid())), std::string::npos)
      << out;
  EXPECT_TRUE(roudi.running()) << "rig up stopped a RouDi it did not start";
  EXPECT_EQ(roudi.stop(10000), 0);
}

TEST(ShmRigConfig, TransportWordIsValidated) {
  test::TempDir dir;
  const auto bad = dir.write("bad.yaml", "rig:\n  dds:\n    transport: tcp\n");
  auto [rc, out] = test::run(rig_bin() + " config check " + bad + " 2>&1");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find(bad + ":3:16: rig.dds.transport"), std::string::npos) << out;
  EXPECT_NE(out.find("udp"), std::string::npos) << "the allowed words are named: " << out;
  const auto stray = dir.write("stray.yaml", "rig:\n  dds: {transport: udp, roudi_config: " + bad + "}\n");
  std::tie(rc, out) = test::run(rig_bin() + " config check " + stray + " 2>&1");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find("only used with transport: shm"), std::string::npos) << out;
  const auto good = dir.write("good.yaml", "rig:\n  dds: {transport: shm}\n");
  std::tie(rc, out) = test::run(rig_bin() + " config check " + good + " 2>&1");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("transport shm"), std::string::npos) << out;
  // A monitor over shm without any RouDi: a clear error at once, not iceoryx's 60 s wait and abort.
  if (dds::probe_roudi().pid == 0) {
    const Nanos t0 = monotonic_now_ns();
    std::tie(rc, out) = test::run(rig_bin() + " monitor --duration 1 --transport shm --dds-profile " + profile() + " 2>&1");
    EXPECT_EQ(rc, 1) << out;
    EXPECT_NE(out.find("needs a running iceoryx RouDi"), std::string::npos) << out;
    EXPECT_LT(monotonic_now_ns() - t0, 3'000'000'000);
  }
}

// rig.dds.shm: the mempools rig up would use, sized from the config (config check prints them),
// and explicit ones validated where they are written: out of order, too small for a VLP-16's cloud.
TEST(ShmRigConfig, MempoolsAreSizedFromTheConfigOrValidatedAtTheirKey) {
  test::TempDir dir;
  // A real VLP-16 said to turn at 600 rpm (not said, it is sized for its slowest, 300: twice this).
  const std::string lidar = "lidars:\n  - {name: front, model: VLP-16, port: 2399, position_port: 0, rpm: 600}\n";
  const auto sized = dir.write("sized.yaml", "rig:\n  dds: {transport: shm, shm: {subscribers: 2}}\n" + lidar);
  auto [rc, out] = test::run(rig_bin() + " config check " + sized + " 2>&1");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("shm: RouDi mempools sized for 2 subscribers per topic: 1024 B x 2048 16384 B x 512 786432 B x "),
            std::string::npos)
      << out;
  const auto unordered = dir.write("unordered.yaml",
                                   "rig:\n  dds:\n    transport: shm\n    shm:\n      mempools:\n"
                                   "        - {size: 2097152, count: 4}\n        - {size: 1024, count: 4}\n" + lidar);
  std::tie(rc, out) = test::run(rig_bin() + " config check " + unordered + " 2>&1");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find(unordered + ":7:18: "), std::string::npos) << out;
  EXPECT_NE(out.find("pool sizes must ascend (iceoryx refuses them otherwise): 1024 after 2097152"), std::string::npos)
      << out;
  const auto small = dir.write("small.yaml", "rig:\n  dds:\n    transport: shm\n    shm:\n      mempools: "
                                             "[{size: 1024, count: 64}, {size: 65536, count: 8}]\n" + lidar);
  std::tie(rc, out) = test::run(rig_bin() + " config check " + small + " 2>&1");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find(small + ":5:17: "), std::string::npos) << out;
  EXPECT_NE(out.find("/sensors/lidar/front/points needs chunks of 721280 B"), std::string::npos) << out;
}

}  // namespace
}  // namespace sensor_rig
