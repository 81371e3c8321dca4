// Issue 29, `rig view` against `rig up`: the mock rig (a synthetic VLP-16 and a GigE-fake camera,
// 320x240 BayerRG8) in one process, `rig record` of its cloud and image in another (what the drivers
// published, as the ground truth: read back by @mcap/core and decoded by
// @foxglove/rosmsg2-serialization, tests/js/mcap_dump.mjs), `rig view` in a third, and the Foxglove
// client written by others (tests/js/view_client.mjs: @foxglove/ws-protocol, decoding with the
// schemas rig view advertised) in a fourth. Every cloud and image the client decodes must be one the
// rig published, byte-equal (FNV-1a of the data), with its size (the cloud's width*height and
// point_step, the image's size and encoding as the camera is configured), none skipped between the
// client's first and last; and `rig view` listens on loopback only and leaves the host as it found
// it (tests/support/host_state.sh's snapshot before it starts and after it exits, rig up running).
#include <sys/socket.h>
#include <netinet/in.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "dds_domain_lease.hpp"
#include "rig_process.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "view_client.hpp"
#include "wait.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig {
namespace {

using nlohmann::json;

std::string rig_bin() { return std::getenv("RIG_BIN") != nullptr ? std::getenv("RIG_BIN") : RIG_DEFAULT_BIN; }
std::string profile() { return (test::source_dir() / "config/cyclonedds/loopback.xml").string(); }

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// (exit code, stdout) of a shell command.
std::pair<int, std::string> run(const std::string& cmd) {
  std::string out;
  FILE* f = ::popen(cmd.c_str(), "r");
  if (f == nullptr) return {-1, out};
  char buf[65536];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
  const int st = ::pclose(f);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

// Local addresses (hex, as /proc/net/tcp{,6} has them) of the sockets listening on `port`.
std::vector<std::string> listening_on(int port) {
  std::vector<std::string> r;
  char want[8];
  std::snprintf(want, sizeof want, "%04X", port);
  for (const char* f : {"/proc/net/tcp", "/proc/net/tcp6"}) {
    std::istringstream in(read_all(f));
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      std::istringstream l(line);
      std::string sl, local, remote, state;
      l >> sl >> local >> remote >> state;
      const auto colon = local.rfind(':');
      if (state == "0A" && colon != std::string::npos && local.substr(colon + 1) == want)
        r.push_back(std::string(f) + " " + local.substr(0, colon));
    }
  }
  return r;
}

// The host as tests/support/host_state.sh sees it (addresses on lo, interfaces, namespaces, /dev/shm,
// the rig's state and /tmp entries, socket-buffer sysctls, orphaned processes).
std::string host_state(const std::filesystem::path& file) {
  const auto script = test::source_dir() / "tests/support/host_state.sh";
  const auto build = std::filesystem::path(rig_bin()).parent_path();
  run("bash " + script.string() + " snapshot " + file.string() + " " + build.string() + " >/dev/null 2>&1");
  return read_all(file);
}

TEST(RigViewAgainstRigUp, CloudsAndImagesArriveAsTheMockRigPublishedThemAndTheHostIsUntouched) {
  const std::string missing = test::view_client_missing();
  if (!missing.empty()) GTEST_FAIL() << missing;
  char tmpl[] = "/tmp/rig-view-up-XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  const std::filesystem::path dir = tmpl;
  struct Remove {
    std::filesystem::path p;
    ~Remove() {
      std::error_code ec;
      std::filesystem::remove_all(p, ec);
    }
  } remove{dir};

  const int domain = test::lease_dds_domain();
  const int p = static_cast<int>(::getpid());
  const std::string tag = "view" + std::to_string(p);
  const std::string addr = "127.5." + std::to_string(p / 250 % 250) + "." + std::to_string(1 + p % 250);
  const std::string cloud = "/sensors/lidar/" + tag + "/points";
  const std::string image = "/sensors/camera/" + tag + "_cam/image_raw";
  const std::string config = (dir / "rig.yaml").string();
  std::ofstream(config) << "rig:\n  name: view-rig-up\n  dds: {domain: " << domain << ", profile: " << profile()
                        << "}\nlidars:\n  - name: " << tag << "\n    model: VLP-16\n    port: " << test::free_udp_port()
                        << "\n    position_port: 0\n    realtime_priority: 0\n    mock: {kind: synthetic, rpm: 600}\n"
                        << "cameras:\n  - {name: " << tag << "_cam, backend: aravis, device: " << addr
                        << ", pixel_format: BayerRG8, width: 320, height: 240, frame_rate: 10, mock: {kind: gige}}\n";

  ChildOptions up_opts;
  up_opts.log_file = (dir / "up.log").string();
  ChildProcess up({rig_bin(), "up", config}, up_opts);
  ChildOptions rec_opts;
  rec_opts.log_file = (dir / "rec.log").string();
  const std::string file = (dir / "rec.mcap").string();
  ChildProcess rec({rig_bin(), "record", cloud, image, "--out", file, "--domain", std::to_string(domain),
                    "--dds-profile", profile(), "--compression", "lz4"},
                   rec_opts);
  const auto logs = [&] { return "--- rig up:\n" + read_all(dir / "up.log").substr(0, 3000) + "\n--- rig record:\n" + read_all(dir / "rec.log"); };
  ASSERT_TRUE(test::wait_for([&] { return read_all(dir / "rec.log").find(" 2 topics ") != std::string::npos; },
                             test::kDiscoveryMs, 50))
      << logs();

  // The host with the rig running, before rig view.
  const std::string before = host_state(dir / "host_before");
  ASSERT_FALSE(before.empty());

  const int port = test::free_tcp_port();
  ChildOptions view_opts;
  view_opts.pipe_stdio = true;
  ChildProcess view({rig_bin(), "view", "--domain", std::to_string(domain), "--dds-profile", profile(), "--port",
                     std::to_string(port), "--stats-interval", "0.5"},
                    view_opts);
  json stats = json::object();
  const auto read_stats = [&] {
    for (auto& l : view.read_lines())
      if (auto j = json::parse(l, nullptr, false); !j.is_discarded()) stats = std::move(j);
    return stats;
  };
  ASSERT_TRUE(test::wait_for([&] { return read_stats().value("channels", 0) >= 2; }, test::kDiscoveryMs, 20))
      << read_stats().dump() << logs();
  const auto listening = listening_on(port);
  ASSERT_EQ(listening.size(), 1u) << "rig view's listening sockets on " << port;
  EXPECT_EQ(listening[0], "/proc/net/tcp 0100007F") << "bound to loopback only";

  test::ViewClient c({"--url", "ws://127.0.0.1:" + std::to_string(port), "--wait-topics", cloud + "," + image,
                      "--subscribe", cloud + "," + image, "--count", "20", "--print-messages", "--timeout", "60"});
  ASSERT_TRUE(c.wait_exit(90'000)) << c.transcript();
  EXPECT_EQ(c.exit_status(), 0) << c.transcript();
  EXPECT_TRUE(c.events("decode_error").empty() && c.events("schema_error").empty()) << c.transcript();
  ASSERT_TRUE(test::wait_for([&] { return read_stats().value("clients_closed", 0) == 1; }, 10'000)) << stats.dump();
  view.signal(SIGTERM);
  ASSERT_TRUE(view.wait_exit(10'000));
  EXPECT_EQ(view.exit_status(), 0);
  read_stats();
  EXPECT_EQ(stats.value("final", false), true) << stats.dump();
  EXPECT_EQ(stats.value("protocol_errors", -1), 0) << stats.dump();
  EXPECT_TRUE(listening_on(port).empty());
  // rig view gone, the rig still running: the host as before it started.
  EXPECT_EQ(host_state(dir / "host_after"), before) << "rig view changed the host";

  up.signal(SIGINT);
  ASSERT_TRUE(up.wait_exit(15'000)) << logs();
  EXPECT_EQ(up.exit_status(), 0) << logs();
  rec.signal(SIGINT);
  ASSERT_TRUE(rec.wait_exit(20'000)) << logs();
  EXPECT_EQ(rec.exit_status(), 0) << logs();

  // What the rig published, by header stamp: @mcap/core + rosmsg2-serialization over the recording.
  const auto [rc, out] = run("node " + (test::source_dir() / "tests/js/mcap_dump.mjs").string() + " " + file + " 2>&1");
  const json dump = json::parse(out, nullptr, false);
  ASSERT_TRUE(rc == 0 && !dump.is_discarded() && !dump.contains("error")) << out.substr(0, 2000);
  std::map<std::string, std::map<std::string, json>> published;  // topic -> stamp -> summary
  for (const auto& m : dump["messages"]) published[m["topic"]][m["stamp_ns"].get<std::string>()] = m;
  ASSERT_FALSE(published[cloud].empty());
  ASSERT_FALSE(published[image].empty());

  std::map<std::string, std::vector<std::string>> got;  // topic -> stamps in arrival order
  for (const auto& m : c.events("message")) {
    const std::string topic = m["topic"];
    const std::string stamp = m["stamp_ns"];
    SCOPED_TRACE(topic + " at " + stamp);
    got[topic].push_back(stamp);
    const auto it = published[topic].find(stamp);
    ASSERT_NE(it, published[topic].end()) << "never published (not in the recording)";
    const json& want = it->second;
    const json& s = m["summary"];
    EXPECT_EQ(s["data"]["len"], want["data_len"]);
    EXPECT_EQ(s["data"]["fnv1a"], want["data_fnv"]);
    EXPECT_EQ(s["header"]["frame_id"], want["frame_id"]);
    EXPECT_EQ(s["width"], want["width"]);
    EXPECT_EQ(s["height"], want["height"]);
    if (topic == cloud) {
      EXPECT_EQ(s["point_step"], want["point_step"]);
      EXPECT_GT(s["width"].get<std::uint64_t>(), 1000u);  // a VLP-16 sweep of the synthetic scene
      EXPECT_EQ(s["width"].get<std::uint64_t>() * s["height"].get<std::uint64_t>() * s["point_step"].get<std::uint64_t>(),
                s["data"]["len"].get<std::uint64_t>());
      std::vector<std::string> fields;
      for (const auto& f : s["fields"]) fields.push_back(f["name"]);
      EXPECT_EQ(fields, want["fields"].get<std::vector<std::string>>());
    } else {
      // As the camera is configured: 320x240 BayerRG8, one byte a pixel.
      EXPECT_EQ(s["width"], 320);
      EXPECT_EQ(s["height"], 240);
      EXPECT_EQ(s["encoding"], "bayer_rggb8");
      EXPECT_EQ(s["encoding"], want["encoding"]);
      EXPECT_EQ(s["step"], 320);
      EXPECT_EQ(s["data"]["len"], 320 * 240);
    }
  }
  for (const auto& topic : {cloud, image}) {
    SCOPED_TRACE(topic);
    const auto& stamps = got[topic];
    ASSERT_GE(stamps.size(), 20u) << c.transcript();
    // In order, and none the rig published between the first and the last is missing.
    std::size_t between = 0;
    for (const auto& [stamp, m] : published[topic])
      if (std::stoll(stamp) >= std::stoll(stamps.front()) && std::stoll(stamp) <= std::stoll(stamps.back())) ++between;
    for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_LT(std::stoll(stamps[i - 1]), std::stoll(stamps[i]));
    EXPECT_EQ(stamps.size(), between);
  }
}

}  // namespace
}  // namespace sensor_rig
