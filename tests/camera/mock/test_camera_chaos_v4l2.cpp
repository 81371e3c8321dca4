// The fake V4L2 device under a campaign: its truth record against what V4l2Source reads, and the
// v4l2.* faults (camera/README.md "Mocks: faults and truth").
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "sensor_rig/camera/mock/fake_v4l2_device.hpp"
#include "sensor_rig/camera/v4l2_source.hpp"
#include "chaos_files.hpp"
#include "next_frame.hpp"

namespace sensor_rig::camera {
namespace {

constexpr Nanos kS = 1'000'000'000;

SourceConfig yuyv(double rate = 50) {
  SourceConfig c;
  c.backend = "v4l2";
  c.device = "/dev/video0";
  c.format = PixelFormat::kYuv422Yuyv;
  c.width = 640;
  c.height = 480;
  c.frame_rate = rate;
  c.exposure_us = 4000;
  return c;
}

std::shared_ptr<mock::FakeV4l2Device> device(test::ChaosFolder& folder, const std::vector<std::string>& specs) {
  mock::FakeV4l2Options o;
  o.chaos.device = "usb";
  o.chaos.truth = folder.truth();
  if (!specs.empty()) o.chaos.plan = folder.plan("usb", specs);
  return std::make_shared<mock::FakeV4l2Device>(o);
}

Capture next_frame(FrameSource& s, int budget_ms = 1000) { return test::next_frame(s, budget_ms); }

// Without faults: every frame read is a unit with its sequence, stamp (monotonic) and the same
// instant as vehicle time; every part is sent.
TEST(V4l2Chaos, FaultFreeTruthIsWhatV4l2Reads) {
  test::ChaosFolder folder;
  std::map<std::uint64_t, Nanos> read;
  {
    auto dev = device(folder, {});
    V4l2Source src(yuyv(), dev);
    src.open();
    for (int i = 0; i < 10; ++i) {
      auto c = next_frame(src);
      ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
      read[c.frame.meta().seq] = c.frame.meta().device_ns;
    }
    src.close();
  }
  const auto log = truth::read(folder.truth());
  EXPECT_EQ(log.header.device_class, "v4l2");
  EXPECT_EQ(log.header.topic, "/sensors/camera/usb/image_raw");
  std::map<std::int64_t, truth::UnitRecord> units;
  for (const auto& u : log.units) units[u.unit] = u;
  const double to_vehicle = static_cast<double>(vehicle_now_ns() - monotonic_now_ns());
  for (const auto& [seq, dev] : read) {
    ASSERT_TRUE(units.count(static_cast<std::int64_t>(seq))) << "sequence " << seq;
    EXPECT_EQ(units[static_cast<std::int64_t>(seq)].dev_ns, dev);
    EXPECT_NEAR(static_cast<double>(units[static_cast<std::int64_t>(seq)].acq_ns), static_cast<double>(dev) + to_vehicle, 2e6);
  }
  EXPECT_EQ(test::count_fate(log, truth::Fate::kSent), log.parts.size());
}

// A gap of 4: the sequence V4l2Source reads jumps by 5 once, V4l2Source counts the 4 missing, and
// the truth has exactly those 4 frames dropped (made and lost in the device) with the fault.
TEST(V4l2Chaos, SequenceGapJumpsAndIsRecorded) {
  test::ChaosFolder folder;
  std::uint64_t jumps = 0, jump = 0, last = 0, missing = 0;
  {
    auto dev = device(folder, {"v4l2.sequence_gap:n=4@0.3"});
    V4l2Source src(yuyv(), dev);
    src.open();
    for (int i = 0; i < 40; ++i) {
      auto c = next_frame(src);
      ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
      if (i > 0 && c.frame.meta().seq != last + 1) {
        ++jumps;
        jump = c.frame.meta().seq - last;
      }
      last = c.frame.meta().seq;
    }
    missing = src.stats().missing_frames;
    src.close();
  }
  EXPECT_EQ(missing, 4u);  // issue 27 item 5: the gap is counted, not invisible
  EXPECT_EQ(jumps, 1u);
  EXPECT_EQ(jump, 5u);
  const auto log = truth::read(folder.truth());
  EXPECT_EQ(test::count_fate(log, truth::Fate::kDropped), 4u);
  for (const auto& p : log.parts) {
    if (p.fate == truth::Fate::kDropped) {
      EXPECT_EQ(p.fault, 1u);
    }
  }
  ASSERT_EQ(log.faults.size(), 1u);
  EXPECT_EQ(log.faults[0].kind, "v4l2.sequence_gap");
}

// Disconnect for 0.5 s: ENODEV (V4l2Source reports it disconnected, its reopen fails), then the
// device returns and streams; the slots between are not_sent.
TEST(V4l2Chaos, DisconnectThenReturn) {
  test::ChaosFolder folder;
  auto dev = device(folder, {"v4l2.disconnect@0.4+0.5"});
  const Nanos epoch = monotonic_now_ns();
  V4l2Source src(yuyv(), dev);
  src.open();
  Capture c;
  while (monotonic_now_ns() < epoch + 2 * kS && (c = src.next(50)).status != CaptureStatus::kDisconnected) {
  }
  EXPECT_EQ(c.status, CaptureStatus::kDisconnected);
  EXPECT_LT(monotonic_now_ns(), epoch + 6 * kS / 10);
  src.close();
  EXPECT_THROW(src.open(), CameraError);
  while (monotonic_now_ns() < epoch + 1 * kS) usleep(10'000);
  src.open();
  EXPECT_EQ(next_frame(src).status, CaptureStatus::kFrame);
  src.close();
  dev.reset();
  const auto log = truth::read(folder.truth());
  ASSERT_EQ(log.faults.size(), 1u);
  const auto not_sent = test::count_fate(log, truth::Fate::kNotSent);
  EXPECT_GE(not_sent, 20u);  // 0.5 s at 50 Hz
  EXPECT_LE(not_sent, 30u);
}

// End-of-frame stamps: the buffer says EOF, and the truth's exposure start lies exposure (4 ms) +
// half a period (10 ms) before the stamp; V4l2Source takes exposure + readout off (issue 27 item
// 10: it took a whole period, 20 ms, off).
TEST(V4l2Chaos, StampModeEofStampsTheFramesEnd) {
  test::ChaosFolder folder;
  std::map<std::uint64_t, Nanos> read;
  {
    auto dev = device(folder, {"v4l2.stamp_mode:mode=eof@0+60"});
    V4l2Source src(yuyv(), dev);
    src.open();
    for (int i = 0; i < 5; ++i) {
      auto c = next_frame(src);
      ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
      read[c.frame.meta().seq] = c.frame.meta().device_ns;
    }
    src.close();
  }
  const auto log = truth::read(folder.truth());
  std::map<std::int64_t, truth::UnitRecord> units;
  for (const auto& u : log.units) units[u.unit] = u;
  const Nanos to_vehicle = vehicle_now_ns() - monotonic_now_ns();
  for (const auto& [seq, dev] : read) {
    const auto& u = units[static_cast<std::int64_t>(seq)];
    EXPECT_EQ(u.dev_ns - dev, 14'000'000);  // the source moved the EOF stamp back exposure + readout
    EXPECT_NEAR(static_cast<double>(u.dev_ns + to_vehicle - u.acq_ns), 14e6, 2e6);  // exposure + readout
  }
}

// End-of-frame stamps with the exposure unset (auto): the device's own exposure is not known, the
// fake's 10 ms is assumed with half the granted period of readout: the stamp lands on the truth.
TEST(V4l2Chaos, StampModeEofWithAutoExposureLandsOnTheExposureStart) {
  test::ChaosFolder folder;
  std::map<std::uint64_t, Nanos> read;
  {
    auto dev = device(folder, {"v4l2.stamp_mode:mode=eof@0+60"});
    auto c = yuyv(10);
    c.exposure_us = 0;
    V4l2Source src(c, dev);
    src.open();
    for (int i = 0; i < 3; ++i) {
      auto f = next_frame(src, 2000);
      ASSERT_EQ(f.status, CaptureStatus::kFrame) << f.error;
      read[f.frame.meta().seq] = f.frame.meta().device_ns;
    }
    src.close();
  }
  const auto log = truth::read(folder.truth());
  std::map<std::int64_t, truth::UnitRecord> units;
  for (const auto& u : log.units) units[u.unit] = u;
  const Nanos to_vehicle = vehicle_now_ns() - monotonic_now_ns();
  for (const auto& [seq, dev] : read) {
    const auto& u = units[static_cast<std::int64_t>(seq)];
    EXPECT_NEAR(static_cast<double>(dev + to_vehicle - u.acq_ns), 0.0, 1e6) << seq;
  }
}

}  // namespace
}  // namespace sensor_rig::camera
