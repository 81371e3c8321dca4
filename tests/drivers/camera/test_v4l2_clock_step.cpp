// The fake V4L2 camera while the host's CLOCK_REALTIME is stepped back (stepped_realtime.hpp: this
// process's clock, not the host's), through the camera node's stamp path (V4l2Source ->
// RealtimeStepDetector -> FrameClock, as CameraDriver::publish): every frame's stamp is held
// against the fake's truth record of its exposure start, by its V4L2 sequence.
//
// What `rig chaos` reported as V4L2 frames "published twice, about every 9th frame, stamps ~50 ms
// off": after a host.clock_step back, MonotonicStamps holds the topic's stamps and slews the step
// out at 10 % (timesync/README.md "Realtime steps"), so for ~10x the step each stamp is later than
// its exposure by a correction that shrinks a tenth of a period per frame; matched to the unit
// nearest its stamp, every tenth frame lands on its predecessor's unit. No frame is published
// twice; the stamps are knowingly off vehicle time, and were not flagged.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <map>

#include "sensor_rig/camera/mock/fake_v4l2_device.hpp"
#include "sensor_rig/camera/v4l2_source.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/drivers/camera/frame_clock.hpp"
#include "sensor_rig/timesync/host_clock.hpp"
#include "stepped_realtime.hpp"

namespace sensor_rig::drivers {
namespace {


struct Published {
  Nanos stamp = 0;
  std::uint64_t seq = 0;
  bool slewed = false;
};

TEST(V4l2ClockStep, StampsAgainstTheFakesTruthThroughAStepBack) {
  const std::string dir = "/tmp/rig_v4l2_clock_step_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  struct Cleanup {
    std::string d;
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(d, ec);
    }
  } cleanup{dir};

  camera::SourceConfig cfg;
  cfg.backend = "v4l2";
  cfg.device = "/dev/video0";
  cfg.format = camera::PixelFormat::kYuv422Yuyv;
  cfg.width = 640;
  cfg.height = 480;
  cfg.frame_rate = 20;
  std::vector<Published> published;
  {
    camera::mock::FakeV4l2Options o;
    o.chaos.device = "usb";
    o.chaos.truth = dir + "/truth.jsonl";
    auto dev = std::make_shared<camera::mock::FakeV4l2Device>(o);
    camera::V4l2Source src(cfg, dev);
    src.open();
    FrameClock clock(0);
    timesync::RealtimeStepDetector steps;
    const Nanos end = monotonic_now_ns() + 4'500 * kMs;  // 0.5 s, the step, 3 s of slew, 1 s exact
    bool stepped = false;
    while (monotonic_now_ns() < end) {
      auto c = src.next(50);
      if (c.status != camera::CaptureStatus::kFrame) continue;
      const auto now = clock_pair_now();
      clock.realtime_step(steps.observe(now.vehicle_ns, now.monotonic_ns));
      const auto st = clock.stamp(c.frame.meta());
      published.push_back({st.vehicle_ns, c.frame.meta().seq, st.slewed});
      if (published.size() == 10 && !stepped) {
        test::step_realtime(-300 * kMs);
        stepped = true;
      }
    }
    src.close();
  }
  const auto log = truth::read(dir + "/truth.jsonl");
  std::map<std::int64_t, Nanos> acq;
  for (const auto& u : log.units) acq[u.unit] = u.acq_ns;
  ASSERT_GT(published.size(), 40u);
  int off = 0, off_unflagged = 0;
  std::map<std::int64_t, int> nearest_count;  // rig chaos's matching: the unit nearest the stamp
  for (const auto& p : published) {
    const Nanos err = p.stamp - acq.at(static_cast<std::int64_t>(p.seq));
    EXPECT_GE(err, -kMs) << "seq " << p.seq << ": a stamp before its exposure";
    if (std::llabs(err) > kMs) {
      ++off;
      // The invariant: within 1 ms of the true exposure, or flagged (the node's stamp_sync).
      if (!p.slewed) ++off_unflagged;
      EXPECT_TRUE(p.slewed) << "seq " << p.seq << ": stamp " << static_cast<double>(err) / 1e6 << " ms after the exposure, not flagged";
    }
    std::int64_t best = -1;
    for (const auto& [u, a] : acq)
      if (best < 0 || std::llabs(a - p.stamp) < std::llabs(acq.at(best) - p.stamp)) best = u;
    ++nearest_count[best];
  }
  int twice = 0;
  for (const auto& [u, n] : nearest_count) twice += n > 1 ? n - 1 : 0;
  std::printf("frames %zu: %d stamps > 1 ms off their exposure (%d not flagged), %d matched to a unit twice by stamp\n",
              published.size(), off, off_unflagged, twice);
  EXPECT_GT(off, 0) << "the step back was held and slewed (the policy): stamps late for a while";
  // Slewed out: the last frames are on their exposure again, and no longer flagged.
  const auto& last = published.back();
  EXPECT_LE(std::llabs(last.stamp - acq.at(static_cast<std::int64_t>(last.seq))), kMs);
  EXPECT_FALSE(last.slewed);
}

}  // namespace
}  // namespace sensor_rig::drivers
