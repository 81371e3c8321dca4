// try_realtime_priority(): the calling thread runs SCHED_FIFO where permitted, and says why not
// where refused; out-of-range priorities are rejected before the kernel is asked.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <future>
#include <thread>
#include <unistd.h>

#include "sensor_rig/common/thread_priority.hpp"

namespace sensor_rig {
namespace {

bool may_use_rtprio() {
  rlimit rl{};
  return geteuid() == 0 || (getrlimit(RLIMIT_RTPRIO, &rl) == 0 && rl.rlim_cur >= 10);
}

TEST(ThreadPriority, CallingThreadRunsFifoWherePermitted) {
  std::string sched;
  PriorityResult r;
  std::thread t([&] {  // a thread of its own: the test runner's thread keeps normal scheduling
    r = try_realtime_priority(10);
    sched = current_scheduling();
  });
  t.join();
  if (r.applied) {
    EXPECT_EQ(sched, "SCHED_FIFO 10");
    EXPECT_TRUE(r.why_not.empty());
  } else {
    EXPECT_FALSE(may_use_rtprio()) << "refused although permitted: " << r.why_not;
    EXPECT_FALSE(r.why_not.empty());
    EXPECT_EQ(sched, "SCHED_OTHER 0");
  }
}

TEST(ThreadPriority, OutOfRangeIsRejectedWithReason) {
  for (int bad : {0, -1, 100, 120}) {
    const auto r = try_realtime_priority(bad);
    EXPECT_FALSE(r.applied) << bad;
    EXPECT_NE(r.why_not.find("outside 1..99"), std::string::npos) << r.why_not;
  }
  EXPECT_EQ(current_scheduling(), "SCHED_OTHER 0");
}

TEST(ThreadPriority, AnotherThreadByHandle) {
  std::promise<void> set;
  std::string sched;
  std::thread t([&, go = set.get_future()]() mutable {
    go.wait();  // read the policy only after the main thread set it
    sched = current_scheduling();
  });
  const auto r = try_realtime_priority(t.native_handle(), 11);
  set.set_value();
  t.join();
  EXPECT_EQ(sched, r.applied ? "SCHED_FIFO 11" : "SCHED_OTHER 0") << r.why_not;
  if (!r.applied) {
    EXPECT_FALSE(may_use_rtprio()) << r.why_not;
  }
}

}  // namespace
}  // namespace sensor_rig
