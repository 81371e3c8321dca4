// rig-fake-gige-camera's camera.dies ends as a power cycle: the camera that returns has fresh
// registers and no controller, so nothing of the acquisition it died in reaches the wire again.
// The fake's stream thread ran on until the restart joined it, up to a frame period after the
// fault's end was seen, and its truth said "sent" for a frame of the old acquisition sent to the
// old stream (the host had closed it): rig chaos counted it "neither published nor counted lost"
// (camera-only campaigns, seed 8: corner_front_right frames 65580 and 196493, 66 and 90 ms after
// each camera.dies ended; 2 more in another campaign).
#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include "sensor_rig/camera/aravis_source.hpp"
#include "chaos_files.hpp"
#include "gige_fake_test.hpp"
#include "next_frame.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera {
namespace {

class GigeChaosReboot : public test::GigeFakeTest<240> {};

// As the rig's watchdog does: the host gives up on the dead camera (closes its stream), and opens
// it again once it returned. The first frame sent after the fault's end is the rebooted camera's
// first (its ids start again), never one more of the acquisition it died in.
TEST_F(GigeChaosReboot, ADeadCameraSendsNothingOfItsOldAcquisitionWhenItReturns) {
  auto fake = start({"camera.dies@1.5+1.5"});
  const Nanos epoch = folder_.epoch();
  AravisSource src(cfg());
  src.open();
  ASSERT_EQ(test::next_frame(src, 3000, true).status, CaptureStatus::kFrame);
  while (monotonic_now_ns() < epoch + 2 * kSec) (void)src.next(50);  // dead from 1.5 s
  src.close();  // the host's watchdog: the stream is closed, the camera keeps its acquisition
  while (monotonic_now_ns() < epoch + 34 * kSec / 10) usleep(10'000);  // it returned at 3 s
  src.open();
  {
    const auto c = test::next_frame(src, 3000, true);
    ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
  }
  src.close();
  fake.stop(1000);
  const auto log = truth::read(folder_.truth());
  ASSERT_EQ(log.faults.size(), 1u);
  ASSERT_FALSE(log.units.empty());
  const Nanos until = log.faults[0].until_ns;
  const std::uint64_t first_id = static_cast<std::uint64_t>(log.units.front().unit) & 0xffff;
  bool first_seen = false;
  for (const auto& p : log.parts) {
    if (p.fate != truth::Fate::kSent || p.tx_ns < until) continue;
    const std::uint64_t id = static_cast<std::uint64_t>(p.unit) & 0xffff;
    if (!first_seen) {
      first_seen = true;
      EXPECT_EQ(id, first_id) << "the first frame sent after the camera returned (" << (p.tx_ns - until) / 1'000'000
                              << " ms after) is unit " << p.unit << ", not the rebooted camera's first";
    }
  }
  EXPECT_TRUE(first_seen) << "no frame sent after the camera returned";
}

}  // namespace
}  // namespace sensor_rig::camera
