// host.kill_mock on a LIDAR mock, as `rig up` does it under `rig chaos` (MockFaults kills the real
// `rig lidar replay` process and starts it again with the same plan and truth record): each one-shot
// fault of the plan fires once over the whole campaign, one that fell while the mock was dead is
// recorded as not injected, and the restarted mock still fires its own. Held against what arrived on
// a loopback socket (every datagram's sensor time) and the truth record both runs wrote.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "mock_faults.hpp"
#include "rig_cli.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "velodyne_mock_receiver.hpp"

namespace sensor_rig::rig {
namespace {

namespace fs = std::filesystem;

faults::FaultEvent burst(std::uint64_t id, double at_s, int packets) {
  return faults::FaultEvent{id, "lidar.loss_burst", "front", at_s, 0.0, {{"packets", std::to_string(packets)}}};
}

// Packets of `us` (sorted sensor times) that a steady stream of period `period_us` lacks between its
// first and last element.
std::int64_t holes(const std::vector<std::int64_t>& us, double period_us) {
  std::int64_t n = 0;
  for (std::size_t i = 1; i < us.size(); ++i) n += std::llround(static_cast<double>(us[i] - us[i - 1]) / period_us) - 1;
  return n;
}

TEST(MockRestart, ARestartedLidarMockFiresEachOneShotFaultOnceAndRecordsTheOneThatFellWhileItWasDead) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  const fs::path dir = fs::temp_directory_path() / ("rig_mock_restart_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  test::VelodyneMockReceiver receiver;

  // 0.8 s: a burst the first run fires; 1.2 s: the kill (restart 0.4 s later); 1.4 s: a burst while
  // the mock is dead; 2.3 s: a burst of the restarted run.
  faults::Plan plan;
  plan.epoch_mono_ns = monotonic_now_ns();
  plan.events = {burst(1, 0.8, 10),
                 faults::FaultEvent{2, "host.kill_mock", "front", 1.2, 0.0, {{"restart_s", "0.4"}}},
                 burst(3, 1.4, 5), burst(4, 2.3, 3)};
  const std::string plan_path = (dir / "plan.jsonl").string(), truth_path = (dir / "front.jsonl").string();
  faults::write_plan(plan_path, plan);
  std::vector<MockProcess> mocks = receiver.start_front(
      receiver.mock_argv({"--device", "front", "--truth", truth_path, "--fault-plan", plan_path}), (dir / "mock.log").string());
  std::mutex mutex;
  std::vector<std::int64_t> rx_us;  // sensor times of what arrived, in arrival order
  Nanos first_rx_mono = 0;
  const auto receive = [&](int timeout_ms) {
    const auto arrived = receiver.receive(timeout_ms);
    for (const auto& p : arrived) {
      EXPECT_EQ(p.bytes, test::kVelodynePacket);
      if (p.bytes != test::kVelodynePacket) continue;
      rx_us.push_back(p.sensor_us);
      if (first_rx_mono == 0) first_rx_mono = p.mono;
    }
    return arrived.size();
  };
  {
    MockFaults kills(plan, mocks, mutex, (dir / "host_mocks.jsonl").string());
    while (monotonic_now_ns() < plan.epoch_mono_ns + 2800 * kMs) receive(20);
  }  // no more kills; the restarted mock (a child of that thread) has its SIGTERM
  {
    std::lock_guard lock(mutex);
    mocks[0].child.stop();
  }
  while (receive(50) > 0) {
  }  // what it sent before it ended
  EXPECT_EQ(receiver.source().stats().kernel_drops, 0u);
  ASSERT_GT(first_rx_mono, 0) << "nothing arrived";
  ASSERT_LT(first_rx_mono, plan.epoch_mono_ns + 700 * kMs) << "the first run started too late to fire the first burst";

  const truth::Log log = truth::read(truth_path);
  const truth::Log host = truth::read((dir / "host_mocks.jsonl").string());
  ASSERT_EQ(log.restarts, 1) << "the mock was killed and restarted once";
  ASSERT_EQ(host.faults.size(), 1u);
  const Nanos killed = host.faults[0].at_ns;

  // The truth: fault 1 dropped its 10 packets once (in the first run), fault 3 none, fault 4 its 3.
  std::map<std::uint64_t, std::vector<const truth::PartRecord*>> by_fault;
  for (const auto& p : log.parts)
    if (p.fault != 0) by_fault[p.fault].push_back(&p);
  EXPECT_EQ(by_fault[1].size(), 10u) << "packets fault 1's burst of 10 dropped";
  EXPECT_EQ(by_fault[3].size(), 0u) << "fault 3's time fell while the mock was dead";
  EXPECT_EQ(by_fault[4].size(), 3u);
  for (const auto& [id, parts] : by_fault)
    for (const auto* p : parts) EXPECT_EQ(p->fate, truth::Fate::kDropped) << "fault " << id;
  for (const auto* p : by_fault[1]) EXPECT_LT(p->acq_ns, killed) << "fault 1 fired by the restarted run";
  std::map<std::uint64_t, std::vector<const truth::FaultRecord*>> lines;
  for (const auto& f : log.faults) lines[f.id].push_back(&f);
  ASSERT_EQ(lines[1].size(), 1u);
  EXPECT_GE(lines[1][0]->unit, 0);
  ASSERT_EQ(lines[3].size(), 1u) << "the fault that fell while the mock was dead is in the record";
  EXPECT_EQ(lines[3][0]->unit, -1);
  EXPECT_NE(lines[3][0]->detail.find("not injected"), std::string::npos) << lines[3][0]->detail;
  ASSERT_EQ(lines[4].size(), 1u);
  EXPECT_GE(lines[4][0]->unit, 0);

  // The socket: no dropped part arrived; every part handed to the socket did.
  const std::set<std::int64_t> arrived(rx_us.begin(), rx_us.end());
  EXPECT_EQ(arrived.size(), rx_us.size()) << "a datagram arrived twice";
  for (const auto& p : log.parts) {
    const std::int64_t us = p.dev_ns / 1000;
    if (p.fate == truth::Fate::kDropped) {
      EXPECT_FALSE(arrived.contains(us)) << "dropped part " << p.seq << " arrived";
    }
    if (p.tx_ns > 0) {
      EXPECT_TRUE(arrived.contains(us)) << "part " << p.seq << " sent, never arrived";
    }
  }
  // Each run as the socket saw it: the first lost exactly its burst; the second lost fault 4's 3
  // packets and nothing else, counted from its first part (the old mock dropped its first 15: the
  // bursts of faults 1 and 3 again).
  constexpr std::int64_t kHourUs = 3'600'000'000;
  const auto after = [&](std::int64_t prev, std::int64_t us) {  // `us` on prev's side of the hour
    while (us < prev - kHourUs / 2) us += kHourUs;
    return us;
  };
  std::vector<std::int64_t> seen{rx_us.front()};
  for (std::size_t i = 1; i < rx_us.size(); ++i) seen.push_back(after(seen.back(), rx_us[i]));
  std::size_t split = 1;  // the kill: the longest silence
  for (std::size_t i = 1; i < seen.size(); ++i)
    if (seen[i] - seen[i - 1] > seen[split] - seen[split - 1]) split = i;
  std::vector<std::int64_t> run1(seen.begin(), seen.begin() + static_cast<std::ptrdiff_t>(split));
  std::vector<std::int64_t> run2(seen.begin() + static_cast<std::ptrdiff_t>(split), seen.end());
  const truth::PartRecord* run2_first = nullptr;
  for (const auto& p : log.parts)
    if (p.acq_ns > killed && (run2_first == nullptr || p.acq_ns < run2_first->acq_ns)) run2_first = &p;
  ASSERT_NE(run2_first, nullptr) << "the restarted run made nothing";
  ASSERT_GT(run1.size(), 100u);
  ASSERT_GT(run2.size(), 100u);
  std::vector<std::int64_t> d;
  for (std::size_t i = 1; i < run1.size(); ++i) d.push_back(run1[i] - run1[i - 1]);
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  const double period_us = static_cast<double>(d[d.size() / 2]);
  EXPECT_EQ(holes(run1, period_us), 10);
  // A stand-in for the packet before the restarted run's first: its holes are counted from that first.
  run2.insert(run2.begin(), after(run1.back(), run2_first->dev_ns / 1000) - std::llround(period_us));
  EXPECT_EQ(holes(run2, period_us), 3) << "packets the restarted run lost at the socket, 3 planned (fault 4)";
  fs::remove_all(dir);
}


// The process state the kernel reports (/proc/PID/stat's third field): 'T' stopped, 'S' sleeping.
char state_of(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(in, line);
  const auto close = line.rfind(')');
  return close == std::string::npos || close + 2 >= line.size() ? '?' : line[close + 2];
}

// Each event at its own time: another mock's restart pending does not hold it back (the old loop
// slept through each event's span: this stall came when the kill's restart was done, 0.8 s late).
TEST(MockRestart, AStallDuringAnotherMocksRestartComesAtItsTime) {
  faults::Plan plan;
  plan.epoch_mono_ns = monotonic_now_ns() + 100 * kMs;
  plan.events = {faults::FaultEvent{1, "host.kill_mock", "a", 0.0, 0.0, {{"restart_s", "1"}}},
                 faults::FaultEvent{2, "host.stall_mock", "b", 0.2, 0.0, {{"ms", "400"}}}};
  const std::vector<std::string> argv{"/bin/sleep", "30"};
  std::vector<MockProcess> mocks;
  mocks.push_back(MockProcess{"a", argv, ChildOptions{}, ChildProcess(argv, ChildOptions{})});
  mocks.push_back(MockProcess{"b", argv, ChildOptions{}, ChildProcess(argv, ChildOptions{})});
  const pid_t a0 = mocks[0].child.pid(), b = mocks[1].child.pid();
  std::mutex mutex;
  const fs::path truth = fs::temp_directory_path() / ("rig_mock_stall_" + std::to_string(::getpid()) + ".jsonl");
  const auto at = [&](double s) { std::this_thread::sleep_for(std::chrono::nanoseconds(plan.epoch_mono_ns + static_cast<Nanos>(s * 1e9) - monotonic_now_ns())); };
  char b_in_stall = '?', b_after = '?';
  pid_t a_restarted = 0;
  {
    MockFaults faults(plan, mocks, mutex, truth.string());
    at(0.4);
    b_in_stall = state_of(b);
    at(0.8);
    b_after = state_of(b);
    at(1.2);
    std::lock_guard lock(mutex);
    a_restarted = mocks[0].child.running() ? mocks[0].child.pid() : 0;
  }
  for (auto& m : mocks) m.child.stop(100);
  fs::remove(truth);
  EXPECT_EQ(b_in_stall, 'T') << "b is not stopped 0.2 s into its stall";
  EXPECT_NE(b_after, 'T') << "b still stopped 0.2 s after its stall";
  EXPECT_NE(a_restarted, 0) << "a not restarted";
  EXPECT_NE(a_restarted, a0);
}

}  // namespace
}  // namespace sensor_rig::rig
