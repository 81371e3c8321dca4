// AravisSource against in-process Aravis fakes (arv_fake_device): features in order with the
// ExposureTimeAbs fallback, frames in pool memory, trigger modes, stereo pair stamps.
#include <gtest/gtest.h>
#include <unistd.h>

#include <set>
#include <thread>

#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "next_frame.hpp"

namespace sensor_rig::camera {
namespace {

SourceConfig fake(const std::string& serial, TriggerMode trigger = TriggerMode::kFreeRun, double rate = 20) {
  SourceConfig c;
  c.device = std::string(mock::kFakePrefix) + serial;
  c.format = PixelFormat::kBayerRG8;
  c.width = 640;
  c.height = 480;
  c.frame_rate = rate;
  c.exposure_us = 2000;
  c.trigger = trigger;
  c.trigger_line = "Line0";
  return c;
}

Capture next_frame(FrameSource& s, int budget_ms = 2000) { return test::next_frame(s, budget_ms); }

TEST(AravisInProcess, FreeRunFramesLandInPoolMemoryWithDeviceStamps) {
  AravisSource src(fake("FREE1"), mock::inprocess_fake_opener());
  src.open();
  ASSERT_TRUE(src.is_open());
  const auto d = src.details();
  EXPECT_EQ(d.exposure_feature, "ExposureTimeAbs");  // the fake has no SFNC ExposureTime
  EXPECT_NEAR(d.frame_rate, 20.0, 0.5);
  Nanos last = 0;
  std::set<const std::uint8_t*> buffers;
  for (int i = 0; i < 8; ++i) {
    auto c = next_frame(src);
    ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
    const auto& m = c.frame.meta();
    EXPECT_EQ(m.width, 640u);
    EXPECT_EQ(m.height, 480u);
    EXPECT_EQ(m.step, 640u);
    EXPECT_EQ(m.format, PixelFormat::kBayerRG8);
    EXPECT_EQ(c.frame.data().size(), std::size_t{640} * 480);
    EXPECT_EQ(m.domain, TimeDomain::kDeviceTicks);
    EXPECT_GT(m.device_ns, last);
    EXPECT_LE(m.first_rx_ns, m.complete_ns);
    last = m.device_ns;
    buffers.insert(c.frame.data().data());
  }
  EXPECT_LE(buffers.size(), 4u);  // the pool's buffers, reused: no allocation per frame
  EXPECT_GE(src.stats().completed, 8u);
  src.close();
  EXPECT_FALSE(src.is_open());
}

// The exposure the device has since open, read back: the config's, or the device's own when the
// config leaves it (the frame clock's exposure -> first packet delay; the fake's default is 10 ms).
TEST(AravisInProcess, ExposureTimeIsReadBackSetOrLeftAsTheDeviceHasIt) {
  AravisSource set(fake("EXPO1"), mock::inprocess_fake_opener());
  set.open();
  EXPECT_NEAR(set.exposure_us(), 2000.0, 1.0);
  auto c = fake("EXPO2");
  c.exposure_us = 0;
  AravisSource left(c, mock::inprocess_fake_opener());
  left.open();
  EXPECT_TRUE(left.details().exposure_feature.empty());
  EXPECT_NEAR(left.exposure_us(), 10000.0, 1.0);
}

// Frames held past the pool (every buffer out of the stream): the frames the device sends meanwhile
// are Aravis underruns, counted in stats() (the pool is the stream's buffers: one counter for both).
// The in-process fake numbers only the frames it filled, so its ids show no gap.
TEST(AravisInProcess, FramesWhileThePoolIsExhaustedAreCountedUnderruns) {
  auto cfg = fake("UNDER1");
  cfg.buffers = 2;
  AravisSource src(cfg, mock::inprocess_fake_opener());
  src.open();
  auto a = next_frame(src);
  auto b = next_frame(src);
  ASSERT_EQ(a.status, CaptureStatus::kFrame) << a.error;
  ASSERT_EQ(b.status, CaptureStatus::kFrame) << b.error;
  const Nanos until = monotonic_now_ns() + 400'000'000;  // ~8 frames at 20 Hz
  while (monotonic_now_ns() < until) EXPECT_NE(src.next(50).status, CaptureStatus::kFrame);
  EXPECT_GE(src.stats().underruns, 2u);
  a.frame.reset();
  b.frame.reset();
  auto c = next_frame(src);
  ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;  // the pool back: frames again
  src.close();
}

// Aravis' fake camera takes the trigger registers but does not gate frames on them (it runs at
// its trigger frequency): what can be checked against it is what the device was told.
TEST(AravisInProcess, TriggerModesReachTheDevice) {
  {
    AravisSource src(fake("FREERUN"), mock::inprocess_fake_opener());
    src.open();
    EXPECT_EQ(src.feature("TriggerMode"), "Off");
  }
  {
    AravisSource src(fake("SWTRIG", TriggerMode::kSoftware), mock::inprocess_fake_opener());
    src.open();
    EXPECT_EQ(src.feature("TriggerMode"), "On");
    EXPECT_EQ(src.feature("TriggerSource"), "Software");
    EXPECT_TRUE(src.trigger());  // TriggerSoftware executed
    src.close();
    EXPECT_FALSE(src.trigger());  // closed: refused, not a crash
  }
  {
    AravisSource src(fake("LINE", TriggerMode::kLine), mock::inprocess_fake_opener());
    src.open();
    EXPECT_EQ(src.feature("TriggerMode"), "On");
    EXPECT_EQ(src.feature("TriggerSource"), "Line0");
    EXPECT_EQ(src.feature("TriggerActivation"), "RisingEdge");
    EXPECT_FALSE(src.trigger());  // a line-triggered camera is never sent TriggerSoftware
  }
  auto bad = fake("BADLINE", TriggerMode::kLine);
  bad.trigger_line = "Line7";
  AravisSource src(bad, mock::inprocess_fake_opener());
  EXPECT_THROW(src.open(), CameraError);
}

TEST(AravisInProcess, ManyCamerasInOneProcess) {
  std::vector<std::unique_ptr<AravisSource>> cams;
  for (int i = 0; i < 7; ++i) {
    cams.push_back(std::make_unique<AravisSource>(fake("MANY" + std::to_string(i)), mock::inprocess_fake_opener()));
    cams.back()->open();
  }
  for (auto& c : cams) EXPECT_EQ(next_frame(*c).status, CaptureStatus::kFrame);
}

TEST(AravisInProcess, FeaturesTheDeviceLacksAreErrorsNamingThem) {
  {
    auto c = fake("BADFMT");
    c.format = PixelFormat::kYuv422Yuyv;  // not in the fake's PixelFormat enumeration
    AravisSource src(c, mock::inprocess_fake_opener());
    try {
      src.open();
      FAIL() << "opened";
    } catch (const CameraError& e) {
      EXPECT_NE(std::string(e.what()).find("PixelFormat YUV422_8"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(src.is_open());
  }
  {
    auto c = fake("BADFEAT");
    c.features = {{"NoSuchFeature", "3"}};
    AravisSource src(c, mock::inprocess_fake_opener());
    try {
      src.open();
      FAIL() << "opened";
    } catch (const CameraError& e) {
      EXPECT_NE(std::string(e.what()).find("NoSuchFeature"), std::string::npos) << e.what();
    }
  }
  auto nodev = fake("X");
  nodev.device = "no-such-camera-serial";
  AravisSource src(nodev, mock::inprocess_fake_opener());
  EXPECT_THROW(src.open(), CameraError);
}


// Issue 27 item 1: an open that hangs on the network (a camera that does not answer: GVCP timeouts)
// holds no lock a trigger needs: trigger() is refused at once meanwhile, not after the open. Before,
// open() held the camera's lock throughout and the trigger group waited on it.
TEST(AravisInProcess, ATriggerDuringAHangingOpenIsRefusedAtOnce) {
  AravisSource src(fake("HANG1", TriggerMode::kSoftware), [](const std::string& d) -> void* {
    ::usleep(1'200'000);
    throw CameraError("aravis " + d + ": no answer");
  });
  std::thread opener([&] { EXPECT_THROW(src.open(), CameraError); });
  ::usleep(100'000);
  const Nanos t0 = monotonic_now_ns();
  EXPECT_FALSE(src.trigger());
  EXPECT_FALSE(src.is_open());
  const Nanos took = monotonic_now_ns() - t0;
  opener.join();
  EXPECT_LT(took, 50'000'000) << "trigger() waited " << took / 1'000'000 << " ms for the open";
}

}  // namespace
}  // namespace sensor_rig::camera
