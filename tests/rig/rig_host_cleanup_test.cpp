// `rig up` gives back what it adds to the host: a GigE camera mock's address on lo is removed when
// the rig stops (its --duration, SIGINT, SIGTERM), and a rig killed with SIGKILL has its address
// removed by the next `rig up`. The real `rig` in its own process, the real lo (needs root or
// CAP_NET_ADMIN: skipped with the reason otherwise), an address unique to this test process.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include "rig_process.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "wait.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig {
namespace {

class RigHostCleanup : public ::testing::Test {
 protected:
  void SetUp() override {
    const int p = static_cast<int>(::getpid());
    address_ = "127.2." + std::to_string(p / 250 % 250) + "." + std::to_string(1 + p % 250);
    ASSERT_FALSE(host_has_address(address_)) << address_ << " is on the host already";
    std::string why;
    if (!LoopbackAddress::take(address_, why)) GTEST_SKIP() << why;  // taken and given back at once
    const std::string rig = "rig:\n  name: cleanup\n  dds: {domain: " + std::to_string(160 + p % 40) +
                            ", profile: " + (test::source_dir() / "config/cyclonedds/loopback.xml").string() + "}\n";
    with_camera_ = dir_.write("camera.yaml", rig +
                                                 "cameras:\n  - {name: cleanup_cam, backend: aravis, device: " + address_ +
                                                 ", pixel_format: BayerRG8, width: 320, height: 240, frame_rate: 10,"
                                                 " mock: {kind: gige}}\n");
    without_camera_ = dir_.write("none.yaml", rig);
  }

  ChildProcess rig_up(const std::string& config, int duration_s) {
    ChildOptions o;
    o.log_file = (dir_.path / "rig.log").string();
    return ChildProcess({test::rig_bin(), "up", config, "--duration", std::to_string(duration_s)}, o);
  }
  bool address_appears() {
    return test::wait_for([&] { return host_has_address(address_); }, test::kDiscoveryMs, 20);
  }
  std::string log() const { return test::read_text(dir_.path / "rig.log"); }

  test::TempDir dir_;
  std::string address_, with_camera_, without_camera_;
};

TEST_F(RigHostCleanup, TheMocksAddressIsRemovedWhenTheRigStopsByItself) {
  auto rig = rig_up(with_camera_, 3);
  ASSERT_TRUE(address_appears()) << log();
  ASSERT_TRUE(rig.wait_exit(test::kDiscoveryMs)) << log();
  EXPECT_EQ(rig.exit_status(), 0) << log();
  EXPECT_FALSE(host_has_address(address_)) << "rig up ended and left " << address_ << " on lo\n" << log();
}

TEST_F(RigHostCleanup, TheMocksAddressIsRemovedOnSigintAndSigterm) {
  for (const int sig : {SIGINT, SIGTERM}) {
    auto rig = rig_up(with_camera_, 120);
    ASSERT_TRUE(address_appears()) << log();
    rig.signal(sig);
    ASSERT_TRUE(rig.wait_exit(test::kDiscoveryMs)) << "signal " << sig << "\n" << log();
    EXPECT_EQ(rig.exit_status(), 0) << "signal " << sig << "\n" << log();
    EXPECT_FALSE(host_has_address(address_)) << "signal " << sig << " left " << address_ << " on lo\n" << log();
  }
}

TEST_F(RigHostCleanup, AKilledRigsAddressIsRemovedByTheNextRigUp) {
  {
    auto rig = rig_up(with_camera_, 120);
    ASSERT_TRUE(address_appears()) << log();
    rig.signal(SIGKILL);
    ASSERT_TRUE(rig.wait_exit(test::kDiscoveryMs));
  }
  EXPECT_TRUE(host_has_address(address_)) << "a SIGKILLed rig cannot give anything back";
  auto next = rig_up(without_camera_, 1);  // no camera at all: it cleans up before anything else
  ASSERT_TRUE(next.wait_exit(test::kDiscoveryMs)) << log();
  EXPECT_EQ(next.exit_status(), 0) << log();
  EXPECT_FALSE(host_has_address(address_)) << log();
  EXPECT_NE(log().find("removed " + address_ + " from lo"), std::string::npos) << log();
}

}  // namespace
}  // namespace sensor_rig
