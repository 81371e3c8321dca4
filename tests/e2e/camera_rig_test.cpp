// The real `rig` binary with cameras: `rig config check` reports bad camera items at their lines
// (exit 2); `rig up` runs a GigE-fake camera and a fake-V4L2 camera, publishes both; the GigE fake
// killed mid-stream is restarted by `rig up` and its frames resume while the other camera goes on.
#include <gtest/gtest.h>
#include <signal.h>

#include <dirent.h>

#include <fstream>

#include "rig_process.hpp"
#include "test_addresses.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig {
namespace {

std::string rig_bin() {
  const char* b = std::getenv("RIG_BIN");
  return b != nullptr ? b : "rig";
}

// pid of a child of `parent` whose command line contains `needle` (the GigE fake rig up started).
pid_t child_with(pid_t parent, const std::string& needle) {
  DIR* d = ::opendir("/proc");
  pid_t found = -1;
  while (dirent* e = d != nullptr ? ::readdir(d) : nullptr) {
    const pid_t pid = static_cast<pid_t>(std::atoi(e->d_name));
    if (pid <= 0) continue;
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string s((std::istreambuf_iterator<char>(stat)), {});
    const auto rp = s.rfind(')');
    if (rp == std::string::npos) continue;
    pid_t ppid = 0;
    char state = 0;
    if (std::sscanf(s.c_str() + rp + 1, " %c %d", &state, &ppid) != 2 || ppid != parent) continue;
    std::ifstream cl("/proc/" + std::to_string(pid) + "/cmdline");
    std::string cmd((std::istreambuf_iterator<char>(cl)), {});
    for (auto& c : cmd)
      if (c == '\0') c = ' ';
    if (cmd.find(needle) != std::string::npos) found = pid;
  }
  if (d != nullptr) ::closedir(d);
  return found;
}

TEST(CameraRig, ConfigCheckReportsBadCamerasAtTheirLines) {
  test::TempDir dir;
  const auto file = dir.write("bad.yaml", R"(rig: {name: t}
cameras:
  - name: a
    device: 127.0.0.2
    pixel_format: MJPG
    mock: {kind: gige}
  - name: a
    device: 127.0.0.2
    zoom: 3
)");
  const auto [code, out] = test::run(rig_bin() + " config check " + file + " 2>&1");
  EXPECT_EQ(code, 2) << out;
  for (const char* needle : {"bad.yaml:5:", "cannot do 'MJPG'", "duplicate camera name 'a'", "used by two cameras", "bad.yaml:9:", "zoom"})
    EXPECT_NE(out.find(needle), std::string::npos) << needle << "\n" << out;
}

TEST(CameraRig, RigUpPublishesCamerasAndRestartsAKilledGigeFake) {
  test::TempDir dir;
  const std::string tag = std::to_string(::getpid());
  const auto claim = test::TestAddresses::take(100, 199);
  const std::string addr = claim[0];
  const std::string gige = "e2e_gige_" + tag;
  const std::string usb = "e2e_usb_" + tag;
  const auto file = dir.write("cams.yaml", "rig: {name: cams, diagnostics_period_ms: 500}\ncameras:\n"
                                           "  - {name: " + gige + ", backend: aravis, device: " + addr +
                                           ", pixel_format: BayerRG8, width: 640, height: 480, frame_rate: 10, mock: {kind: gige}}\n"
                                           "  - {name: " + usb + ", backend: v4l2, device: /dev/video0, pixel_format: YUYV,"
                                           " width: 640, height: 480, frame_rate: 10, mock: {kind: v4l2-fake}}\n");
  dds::Participant p;
  const auto qos = dds::QosSpec{};
  dds::Topic<msg::Image> gt(p, "/sensors/camera/" + gige + "/image_raw", qos);
  dds::Reader<msg::Image> gr(p, gt, qos);
  dds::Topic<msg::Image> ut(p, "/sensors/camera/" + usb + "/image_raw", qos);
  dds::Reader<msg::Image> ur(p, ut, qos);
  ChildProcess rig({rig_bin(), "up", file, "--duration", "25"});
  int g = 0, u = 0;
  const auto pump = [&] {
    gr.take([&](const msg::Image& m, const dds_sample_info_t&) {
      EXPECT_EQ(static_cast<std::size_t>(m.step) * m.height, m.data._length);
      ++g;
    });
    ur.take([&](const msg::Image&, const dds_sample_info_t&) { ++u; });
  };
  const auto wait = [&](auto done, int ms) {
    const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(ms) * 1'000'000;
    while (!done() && monotonic_now_ns() < deadline) {
      gr.wait(50);
      pump();
    }
    return done();
  };
  ASSERT_TRUE(wait([&] { return g >= 10 && u >= 10; }, 10000)) << "gige " << g << " usb " << u;
  const pid_t fake = child_with(rig.pid(), "-i " + addr);
  if (fake <= 0) {
    rig.stop();
    GTEST_SKIP() << "no GigE fake (address could not be added to lo): in-process fallback ran";
  }
  ::kill(fake, SIGKILL);
  const int g0 = g, u0 = u;
  // The other camera keeps going while the GigE one is down, and the GigE one comes back.
  ASSERT_TRUE(wait([&] { return g >= g0 + 10; }, 8000)) << "gige frames did not resume";
  EXPECT_GE(u, u0 + 10);
  EXPECT_NE(child_with(rig.pid(), "-i " + addr), fake);
  rig.stop(3000);
  EXPECT_EQ(child_with(rig.pid(), "-i " + addr), -1);
}

}  // namespace
}  // namespace sensor_rig
