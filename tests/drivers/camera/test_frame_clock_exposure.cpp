// FrameClock fed with each frame's exposure (auto exposure, chunk data), and the floor of the
// arrivals the mapping lies on: a line few frames saw is flagged, never published as synchronized.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "sensor_rig/drivers/camera/frame_clock.hpp"
#include "sensor_rig/timesync/host_clock.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr Nanos kFloorExposure = 2'000'000;
constexpr Nanos kFloorPeriod = 100'000'000;  // 10 Hz
constexpr Nanos kFloorT0 = 1'800'000'000'000'000'000;

// Frames at 10 Hz with an exposure of 5-15 ms chosen anew for each, delivered 0.1-3 ms after it
// ends; the source tells each frame's exposure with the frame itself (chunk data) or one frame later
// (read from the camera after the frame). The worst stamp error after 10 s, each stamp mapped.
double worst_error_following_exposure(unsigned seed, bool told_with_the_frame) {
  const Nanos t0 = 1'800'000'000'000'000'000;
  FrameClock clock(10'000'000);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<Nanos> exposure(5'000'000, 15'000'000);
  std::uniform_int_distribution<Nanos> jitter(100'000, 3'000'000);
  Nanos prev_exposure = 0;
  double worst = 0;
  for (int i = 1; i <= 200; ++i) {
    const Nanos start = t0 + static_cast<Nanos>(i) * 100'000'000;
    const Nanos e = exposure(rng);
    camera::FrameMeta m;
    m.seq = static_cast<std::uint64_t>(i);
    m.domain = camera::TimeDomain::kDeviceTicks;
    m.device_ns = 3'000'000'000 + (start - t0);
    m.first_rx_ns = start + e + jitter(rng);
    m.complete_ns = m.first_rx_ns + 2'000'000;
    if (told_with_the_frame) {
      m.exposure_seq = m.seq;
      m.exposure_ns = e;
    } else if (i > 1) {
      m.exposure_seq = static_cast<std::uint64_t>(i - 1);
      m.exposure_ns = prev_exposure;
    }
    prev_exposure = e;
    const auto s = clock.stamp(m);
    if (i > 100) {
      EXPECT_EQ(s.source, StampSource::kDeviceMapped) << i;
      worst = std::max(worst, std::abs(static_cast<double>(s.vehicle_ns - start)));
    }
  }
  return worst;
}

// Issue 27 item 9: auto exposure, told one frame later: the mapping follows the exposure start, not
// the shortest exposure's arrival (which biased every stamp by the difference, -5 ms here).
TEST(FrameClock, AnExposureThatChangesEveryFrameIsFollowed) { EXPECT_LT(worst_error_following_exposure(11, false), 1e6); }

// Issue 27 items 3 and 9: a camera in chunk mode tells each frame's exposure in the frame itself
// (ChunkExposureTime: exposure_seq = seq). The mapping must be fed with it at once; it was looked
// for among the frames before (never found), so the mapper starved and the stamps fell back to
// the arrival less the exposure, off by the delivery jitter (up to 3 ms here).
TEST(FrameClock, AFramesOwnExposureFromItsChunkIsFollowed) { EXPECT_LT(worst_error_following_exposure(12, true), 1e6); }

// The line is the lower envelope of the arrivals: right where some frames arrive with the
// transport's minimum delay. A receiving thread held off at most frames (normal priority beside the
// rig's real-time threads on a loaded host) leaves it on the rare prompt frame, or on a late one when
// none came. Whole mock rig campaign (seed 25), corner_front_right: its first frame taken 1.24 ms
// after its leader left, every frame for the next 5 s 2-10 ms late: each stamp 1.24 ms late, the
// mapping "locked", `stamps` broken. Truth: the exposure start. A stamp more than 1 ms off it after
// the lock must be flagged (FrameStamp::floor_unseen, doubtful or replaced); before the lock the
// node flags every stamp (test_camera_unlocked_flag.cpp).
struct FloorRun {
  int mapped = 0;           // stamps from a locked mapping
  int wrong_unflagged = 0;  // of them more than 1 ms off the truth, not flagged
  int wrong_old_rule = 0;   // ... not flagged but for floor_unseen (what the node said before)
  int flagged = 0;
  int right_unflagged_late = 0;  // not flagged, within 1 ms, from the `settled`th frame on
};

template <typename Delay>
FloorRun run_floor(int frames, int settled, Delay delay) {
  FrameClock clock(kFloorExposure);
  FloorRun r;
  for (int i = 0; i < frames; ++i) {
    const Nanos start = kFloorT0 + static_cast<Nanos>(i) * kFloorPeriod;
    camera::FrameMeta m;
    m.seq = static_cast<std::uint64_t>(i + 1);
    m.domain = camera::TimeDomain::kDeviceTicks;
    m.device_ns = 5'000'000'000'000 + (start - kFloorT0);
    m.first_rx_ns = start + kFloorExposure + delay(i);
    m.complete_ns = m.first_rx_ns + 2'000'000;
    const auto s = clock.stamp(m);
    if (s.device_exposure_ns == 0) continue;
    ++r.mapped;
    const bool wrong = std::llabs(s.vehicle_ns - start) > 1'000'000;
    const bool flagged_before = s.doubtful || s.replaced;
    const bool flagged = flagged_before || s.floor_unseen;
    r.wrong_unflagged += wrong && !flagged ? 1 : 0;
    r.wrong_old_rule += wrong && !flagged_before ? 1 : 0;
    r.flagged += flagged ? 1 : 0;
    r.right_unflagged_late += i >= settled && !wrong && !flagged ? 1 : 0;
  }
  return r;
}

TEST(FrameClock, ALineOnAFloorFewFramesSawIsFlagged) {
  // The campaign's record: 1.24 ms, then 54 frames 2-10 ms late, a prompt one (0.07 ms), then as
  // that camera ran for the rest of it: one frame in ten prompt.
  std::mt19937 rng(25);
  std::uniform_int_distribution<Nanos> late(2'000'000, 10'000'000), prompt(30'000, 100'000);
  std::uniform_int_distribution<int> one_in(0, 9);
  const auto held_off = [&](int i) -> Nanos {
    if (i == 0) return 1'243'000;
    if (i == 55) return 71'000;
    return i > 55 && one_in(rng) == 0 ? prompt(rng) : late(rng);
  };
  const FloorRun off = run_floor(300, 0, held_off);
  std::printf("held off: %d mapped, %d flagged, %d more than 1 ms off unflagged (%d before floor_unseen)\n", off.mapped, off.flagged,
              off.wrong_unflagged, off.wrong_old_rule);
  EXPECT_GT(off.wrong_old_rule, 20) << "the case does what the campaign saw";
  EXPECT_EQ(off.wrong_unflagged, 0);
  EXPECT_GT(off.flagged, 200) << "one prompt frame in ten is a floor seen in ~5 of 25 buckets";

  // A receiver at real-time priority (the same campaign: 23-25 of every 25 buckets prompt): after the
  // lock nothing is flagged, every stamp within 1 ms.
  std::uniform_int_distribution<int> one_in_20(0, 19);
  const auto realtime = [&](int) -> Nanos { return one_in_20(rng) == 0 ? late(rng) : prompt(rng); };
  const FloorRun rt = run_floor(300, 20, realtime);
  std::printf("real-time: %d mapped, %d flagged, %d within 1 ms unflagged after 2 s\n", rt.mapped, rt.flagged, rt.right_unflagged_late);
  EXPECT_EQ(rt.flagged, 0);
  EXPECT_EQ(rt.right_unflagged_late, 280);

  // Whatever share of frames is prompt, a stamp more than 1 ms off is never published unflagged.
  for (const int per_mille : {0, 5, 20, 50, 100, 200, 500, 1000}) {
    int wrong = 0, old_wrong = 0, flagged = 0;
    for (unsigned seed = 1; seed <= 10; ++seed) {
      std::mt19937 g(seed);
      std::uniform_int_distribution<int> draw(0, 999);
      const auto mixed = [&](int) -> Nanos { return draw(g) < per_mille ? prompt(g) : late(g); };
      const FloorRun f = run_floor(400, 0, mixed);
      wrong += f.wrong_unflagged;
      old_wrong += f.wrong_old_rule;
      flagged += f.flagged;
    }
    std::printf("prompt %4d per mille: %5d flagged, %d wrong unflagged (before floor_unseen: %d)\n", per_mille, flagged, wrong, old_wrong);
    EXPECT_EQ(wrong, 0) << per_mille << " per mille prompt";
  }
}

}  // namespace
}  // namespace sensor_rig::drivers
