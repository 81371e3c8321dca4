#pragma once
// A test fixture with rig-fake-gige-camera on a loopback address of its own (leased: taken from
// `lo` again when the test ends, also when it fails), a fault plan and a truth record per test.
// kBase: the first of ten addresses 127.0.0.kBase.. the fixture's tests pick from, one that no other
// test process holds (test_addresses.hpp), so that two tests running at once never share a fake.
#include <gtest/gtest.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "chaos_files.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "test_addresses.hpp"

namespace sensor_rig::camera::test {

template <int kBase>
class GigeFakeTest : public ::testing::Test {
 protected:
  [[nodiscard]] std::string address() const { return claim_[0]; }
  void SetUp() override {
    std::string why;
    auto lease = LoopbackAddress::take(address(), why);
    if (!lease) GTEST_SKIP() << why;
    lease_.push_back(std::move(*lease));
  }
  // The fake on this test's address with the plan (none: no faults) and a truth record.
  ChildProcess start(const std::vector<std::string>& specs) {
    mock::GigeFakeOptions o;
    o.address = address();
    o.program = RIG_FAKE_GIGE_CAMERA;
    o.chaos.device = "cam";
    o.chaos.truth = folder_.truth();
    if (!specs.empty()) o.chaos.plan = folder_.plan("cam", specs);
    return mock::start_gige_fake(o);
  }
  // 320x200 Bayer at 20 Hz from this test's fake.
  [[nodiscard]] SourceConfig cfg() const {
    SourceConfig c;
    c.device = address();
    c.format = PixelFormat::kBayerRG8;
    c.width = 320;
    c.height = 200;
    c.frame_rate = 20;
    return c;
  }
  sensor_rig::test::TestAddresses claim_ = sensor_rig::test::TestAddresses::take(kBase, kBase + 9);  // before the lease, gone after it
  ChaosFolder folder_;
  std::vector<LoopbackAddress> lease_;
};

}  // namespace sensor_rig::camera::test
