// The capture -> worker hand-off: offer() never waits for a slow (here: blocked) worker, keeps at
// most `depth` frames queued, drops and counts the oldest, and the worker sees the newest.
#include <gtest/gtest.h>
#include <unistd.h>

#include <condition_variable>
#include <mutex>
#include <vector>

#include "sensor_rig/drivers/camera/frame_worker.hpp"
#include "wait.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

// A worker whose process() blocks until the gate opens and records the frame's first byte.
struct Gated {
  std::mutex m;
  std::condition_variable cv;
  bool open = false;
  std::vector<std::uint64_t> seen;  // meta.seq of each processed frame
  std::vector<std::uint8_t> bytes;  // and its first byte (the copy is the frame's content)
  void process(const WorkerJob& j) {
    std::unique_lock lock(m);
    seen.push_back(j.meta.seq);
    bytes.push_back(j.data[0]);
    cv.wait_for(lock, std::chrono::seconds(10), [&] { return open; });
  }
  void release() {
    {
      std::lock_guard lock(m);
      open = true;
    }
    cv.notify_all();
  }
  std::size_t count() {
    std::lock_guard lock(m);
    return seen.size();
  }
};

void offer_burst(int depth) {
  Gated g;
  FrameWorker w("test_worker", 4096, depth, [&](const WorkerJob& j) { g.process(j); });
  w.start();
  std::vector<std::uint8_t> frame(4096);
  camera::FrameMeta meta;
  // The first frame reaches the worker, which then blocks.
  meta.seq = 0;
  frame[0] = 0;
  ASSERT_TRUE(w.offer(meta, 0, frame));
  ASSERT_TRUE(wait_for([&] { return g.count() == 1; }, 30'000));
  // 100 more while it is blocked: each offer returns at once (a copy and two short locks).
  constexpr int kBurst = 100;
  Nanos worst = 0;
  for (int i = 1; i <= kBurst; ++i) {
    meta.seq = static_cast<std::uint64_t>(i);
    frame[0] = static_cast<std::uint8_t>(i);
    const Nanos t0 = monotonic_now_ns();
    ASSERT_TRUE(w.offer(meta, 0, frame));
    worst = std::max(worst, monotonic_now_ns() - t0);
  }
  // A producer that waited for the worker would sit out the gate's 10 s; 500 ms leaves room for a
  // loaded machine's scheduling without hiding a wait.
  EXPECT_LT(worst, 500'000'000) << "offer() waited " << worst / 1000 << " us for a blocked worker";
  auto c = w.counters();
  EXPECT_EQ(c.offered, static_cast<std::uint64_t>(kBurst + 1));
  EXPECT_EQ(c.processed, 0u);  // still in the first one
  EXPECT_EQ(c.dropped, static_cast<std::uint64_t>(kBurst - depth));
  g.release();
  ASSERT_TRUE(wait_for([&] { return w.counters().processed == static_cast<std::uint64_t>(1 + depth); }, 30'000));
  w.stop();
  // The worker saw the first frame and then exactly the newest `depth` ones, oldest first.
  std::vector<std::uint64_t> want{0};
  for (int i = kBurst - depth + 1; i <= kBurst; ++i) want.push_back(static_cast<std::uint64_t>(i));
  EXPECT_EQ(g.seen, want);
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ(g.bytes[i], static_cast<std::uint8_t>(want[i])) << i;
}

TEST(FrameWorker, BlockedWorkerNeverBlocksTheProducerDepth1) { offer_burst(1); }
TEST(FrameWorker, BlockedWorkerNeverBlocksTheProducerDepth2) { offer_burst(2); }

TEST(FrameWorker, OversizeFramesAreCountedNotQueued) {
  std::atomic<int> processed{0};
  FrameWorker w("test_worker", 16, 1, [&](const WorkerJob&) { ++processed; });
  w.start();
  std::vector<std::uint8_t> big(17), ok(16);
  EXPECT_FALSE(w.offer({}, 0, big));
  EXPECT_TRUE(w.offer({}, 0, ok));
  ASSERT_TRUE(wait_for([&] { return w.counters().processed == 1; }, 30'000));
  EXPECT_EQ(w.counters().oversize, 1u);
  EXPECT_EQ(processed.load(), 1);
}

TEST(FrameWorker, StopsWithFramesQueued) {
  Gated g;
  auto w = std::make_unique<FrameWorker>("test_worker", 64, 2, [&](const WorkerJob& j) { g.process(j); });
  w->start();
  std::vector<std::uint8_t> frame(64);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(w->offer({}, 0, frame));
  ASSERT_TRUE(wait_for([&] { return g.count() == 1; }, 30'000));
  g.release();
  w.reset();  // joins: the destructor must not hang with frames queued
  SUCCEED();
}

}  // namespace
}  // namespace sensor_rig::drivers
