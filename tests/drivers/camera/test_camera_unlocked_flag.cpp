// A device-tick camera's stamps before its clock mapping locks (after every open) are the arrival
// less the exposure, carrying the frame's transport and host delay, which the rig cannot see: the
// node flags its topic `stamp_sync: unsynchronized` from such a stamp, held 2 s (f17a066). Frames
// are fed one at a time by the test (a fake device whose clock runs 30 ppm fast from its own
// epoch, restarted at every open); after each the node's /diagnostics status is read and held
// against the mapping's real lock: the same frames through a FrameClock of their own, the one the
// node stamps with, locked or not after each frame.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include "sensor_rig/camera/calibration.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/camera/camera_driver.hpp"
#include "sensor_rig/drivers/camera/frame_clock.hpp"
#include "status_value.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

// A camera whose frames the test hands over one at a time: next() returns what was pushed, or a
// disconnect when asked. calls() counts next() calls: a call after frame i was handed over means
// the node finished with it (stamped it and updated its status) and waits for the next.
class FedCamera : public camera::FrameSource {
 public:
  static constexpr Nanos kExposureNs = 5'000'000;
  void open() override {
    std::lock_guard lock(mutex_);
    open_ = true;
    ++opens_;
  }
  void close() noexcept override {
    std::lock_guard lock(mutex_);
    open_ = false;
  }
  [[nodiscard]] bool is_open() const noexcept override {
    std::lock_guard lock(mutex_);
    return open_;
  }
  camera::Capture next(int timeout_ms) override {
    camera::Capture c;
    std::unique_lock lock(mutex_);
    ++calls_;
    cv_.notify_all();
    cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [&] { return !queue_.empty() || disconnect_; });
    if (disconnect_) {
      disconnect_ = false;
      c.status = camera::CaptureStatus::kDisconnected;
      c.error = "unplugged by the test";
      return c;
    }
    if (queue_.empty()) return c;  // timeout
    c.status = camera::CaptureStatus::kFrame;
    c.frame = camera::Frame(queue_.front(), {pixels_.data(), pixels_.size()}, [] {});
    queue_.pop_front();
    taken_by_call_ = calls_;
    return c;
  }
  // Hands a frame over and returns once the node is done with it: taken, and next() called again
  // (the node stamped it and updated its status in between). False: not taken within 2 s.
  bool feed(const camera::FrameMeta& m) {
    std::unique_lock lock(mutex_);
    queue_.push_back(m);
    cv_.notify_all();
    return cv_.wait_for(lock, std::chrono::seconds(2), [&] { return queue_.empty() && calls_ > taken_by_call_; });
  }
  void unplug() {
    std::lock_guard lock(mutex_);
    disconnect_ = true;
    cv_.notify_all();
  }
  [[nodiscard]] int opens() const {
    std::lock_guard lock(mutex_);
    return opens_;
  }
  [[nodiscard]] camera::SourceStats stats() const override { return {}; }
  [[nodiscard]] double exposure_us() const override { return static_cast<double>(kExposureNs) / 1000.0; }
  [[nodiscard]] std::string describe() const override { return "fed camera"; }

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
  bool disconnect_ = false;
  int opens_ = 0;
  std::uint64_t calls_ = 0;
  std::uint64_t taken_by_call_ = 0;  // the next() call that returned the last frame
  std::deque<camera::FrameMeta> queue_;
  std::vector<std::uint8_t> pixels_ = std::vector<std::uint8_t>(64, 0);
};

struct Seen {
  int frame = 0;
  bool locked = false;    // the mapping (the reference FrameClock) locked once this frame was stamped
  Nanos since_unlocked = 0;  // CLOCK_MONOTONIC since the last frame stamped before the lock (0: this one)
  std::string stamp_sync;
  std::string sync;
  std::string message;
};

// The hold the node keeps a flag for after the last frame that raised it (camera_driver.cpp).
constexpr Nanos kHoldNs = 2'000'000'000;
// Scheduling slack around the hold's end: frames this close to it are not judged.
constexpr Nanos kHoldSlackNs = 150'000'000;

TEST(CameraDriver, StampsBeforeTheClockMappingLocksAreFlaggedAfterEveryOpen) {
  dds::Participant p;
  dds::StampsWriter stamps(p);
  CameraConfig c;
  c.name = "drv_unlocked_" + std::to_string(::getpid());
  c.frame_id = "camera_" + c.name;
  c.source.format = camera::PixelFormat::kMono8;
  c.source.width = 8;
  c.source.height = 8;
  c.source.frame_rate = 20;
  c.info = camera::uncalibrated(8, 8);
  auto src = std::make_unique<FedCamera>();
  FedCamera* cam = src.get();
  CameraDriver driver(c, std::move(src), p, stamps);
  driver.start();
  ASSERT_TRUE(wait_for([&] { return cam->opens() == 1; }, 30'000));

  FrameClock reference(FedCamera::kExposureNs);
  constexpr Nanos kPeriodNs = 50'000'000;
  std::vector<Seen> seen;
  std::uint64_t seq = 0;
  // One open's frames at 20 Hz: `frames` of them, or (after_lock >= 0) until the mapping locked and `after_lock` more came.
  const auto stream = [&](int frames, int after_lock) {
    const Nanos epoch_mono = monotonic_now_ns();
    const Nanos device_epoch = 7'000'000'000 + static_cast<Nanos>(seq) * 1'000'000;  // restarts at every open
    Nanos last_unlocked = 0;
    int locked_for = 0;
    for (int i = 0; i < frames && (after_lock < 0 || locked_for < after_lock); ++i) {
      const Nanos due = epoch_mono + (i + 1) * kPeriodNs;
      if (const Nanos now = monotonic_now_ns(); due > now) ::usleep(static_cast<useconds_t>((due - now) / 1000));
      // The first packet arrives now: after the exposure and a transport delay of 0.3 ms, 2.5 ms
      // every fifth frame (a loaded host). The device stamped the exposure start in its ticks.
      const auto rx_pair = clock_pair_now();
      const Nanos rx = rx_pair.vehicle_ns, rx_mono = rx_pair.monotonic_ns;
      const Nanos delay = i % 5 == 4 ? 2'500'000 : 300'000;
      const Nanos exposure_mono = rx_mono - delay - FedCamera::kExposureNs;
      camera::FrameMeta m;
      m.seq = ++seq;
      m.width = 8;
      m.height = 8;
      m.step = 8;
      m.format = camera::PixelFormat::kMono8;
      m.domain = camera::TimeDomain::kDeviceTicks;
      m.device_ns = device_epoch + static_cast<Nanos>(static_cast<double>(exposure_mono - epoch_mono) * (1.0 + 30e-6));
      m.first_rx_ns = rx;
      m.complete_ns = rx;
      m.complete_mono_ns = rx_mono;
      (void)reference.stamp(m);
      const bool locked = reference.status(rx).state == timesync::SyncState::kLocked;
      ASSERT_TRUE(cam->feed(m)) << "frame " << m.seq << " not taken";
      const Nanos now = monotonic_now_ns();
      if (!locked) last_unlocked = now;
      locked_for += locked ? 1 : 0;
      const auto st = driver.status();
      seen.push_back({static_cast<int>(m.seq), locked, last_unlocked == 0 ? -1 : now - last_unlocked, test::status_value(st, "stamp_sync"),
                      test::status_value(st, "sync"), st.message});
    }
  };

  // First open: past the lock (~1 s of frames) and 2.5 s more, past the flag's hold.
  stream(static_cast<int>((3'600'000'000 + kHoldNs / 4) / kPeriodNs), -1);
  const std::size_t first_open = seen.size();
  // The device goes away and comes back: a new open, a new mapping from nothing.
  cam->unplug();
  ASSERT_TRUE(wait_for([&] { return cam->opens() == 2; }, 30'000));
  reference.reset(FedCamera::kExposureNs);
  stream(60, 5);
  driver.stop();

  int flagged_before = 0, flagged_in_hold = 0, clear_after = 0, locks = 0;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const Seen& s = seen[i];
    const bool first_of_open = i == 0 || i == first_open;
    if (!first_of_open && s.locked && !seen[i - 1].locked) {
      ++locks;
      std::printf("open %d: mapping locked at frame %d (%zu frames after the open)\n", i < first_open ? 1 : 2, s.frame,
                  i < first_open ? i + 1 : i - first_open + 1);
    }
    // The node's own mapping says what the reference says.
    EXPECT_EQ(s.sync == "locked", s.locked) << "frame " << s.frame << ": node sync " << s.sync;
    if (!s.locked) {
      // Stamped from the arrival less the exposure: flagged, with the reason.
      EXPECT_EQ(s.stamp_sync, "unsynchronized") << "frame " << s.frame << " stamped before the clock mapping locked";
      EXPECT_NE(s.message.find("not mapped yet"), std::string::npos) << "frame " << s.frame << ": " << s.message;
      ++flagged_before;
    } else if (s.since_unlocked < kHoldNs - kHoldSlackNs) {
      EXPECT_EQ(s.stamp_sync, "unsynchronized") << "frame " << s.frame << ": " << s.since_unlocked / 1'000'000
                                                << " ms after the last unmapped stamp, within the hold";
      ++flagged_in_hold;
    } else if (s.since_unlocked > kHoldNs + kHoldSlackNs) {
      EXPECT_EQ(s.stamp_sync, "ok") << "frame " << s.frame << ": " << s.since_unlocked / 1'000'000
                                    << " ms after the last unmapped stamp, the mapping locked";
      EXPECT_EQ(s.message, "running") << "frame " << s.frame;
      ++clear_after;
    }
  }
  std::printf("%zu frames: %d stamped before a lock (flagged), %d after it within the hold, %d after it clear\n", seen.size(),
              flagged_before, flagged_in_hold, clear_after);
  EXPECT_EQ(locks, 2) << "the mapping locked once per open";
  // ~1 s of frames before each lock (5 buckets of 200 ms, 1 s span), the hold's 2 s after the first.
  EXPECT_GE(flagged_before, 2 * 15);
  EXPECT_GE(flagged_in_hold, 30);
  EXPECT_GE(clear_after, 5);
  // The second open's first frame comes 2 s after the first open's last unmapped stamp: it is
  // flagged by its own stamp, not by the hold.
  ASSERT_GT(seen.size(), first_open);
  EXPECT_FALSE(seen[first_open].locked);
  EXPECT_GT(seen[first_open - 1].since_unlocked, kHoldNs + kHoldSlackNs);
}

}  // namespace
}  // namespace sensor_rig::drivers
