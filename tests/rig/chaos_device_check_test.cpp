// The judge of `rig chaos` on cameras and on every device's isolation and recovery: frames are their
// units by frame id, a starved device breaks isolation, recovery is the first whole unit after a
// fault (the LIDAR's truth of chaos_check_fixture.hpp beside the cameras' own).
#include <gtest/gtest.h>

#include "chaos_check.hpp"
#include "chaos_check_fixture.hpp"

namespace sensor_rig::rig::chaos {
namespace {


// A V4L2 camera after a host clock step back: the rig holds its stamps and slews the step out (the
// topic never goes back), so frames 20..44 are stamped 240..0 ms after their exposure, less 10 ms a
// frame. Matched by stamp, every tenth landed on its predecessor's frame: "published twice" and
// unaccounted, as the whole-rig campaign reported. A camera frame is its unit by frame id (sequence):
// nothing is lost, and the slewed stamps are what they are, stamp errors: `stamps` breaks unless the
// rig flagged them (stamp_sync), and then they are flagged.
TEST(ChaosCheck, CameraFramesAreTheirUnitsByFrameIdSoSlewedStampsAreStampErrors) {
  const std::string topic = "/sensors/camera/usb/image_raw";
  Input in;
  truth::Log log;
  log.header = truth::Header{"usb", "v4l2", "fake", topic, "frame", "CLOCK_MONOTONIC"};
  for (int u = 0; u < kScans; ++u) {
    const Nanos acq = kT0 + u * kPeriod;
    log.units.push_back(truth::UnitRecord{u, acq, acq, 1});
    log.parts.push_back(truth::PartRecord{static_cast<std::uint64_t>(u), u, acq, acq, acq, truth::Fate::kSent, 0});
    SampleRecord s;
    s.topic = topic;
    s.seq = static_cast<std::uint64_t>(u);
    const Nanos correction = u >= 20 && u < 45 ? (44 - u) * 10'000'000 : 0;
    s.acquisition_ns = acq + correction;
    s.first_rx_ns = acq;  // the buffer's CLOCK_MONOTONIC stamp in vehicle time: never slewed
    s.publish_ns = acq + 5'000'000;
    s.received_ns = s.publish_ns + 1'000'000;
    s.packets = 1;
    in.samples.push_back(s);
  }
  in.truths.push_back(log);
  in.monitor[topic] = MonitorTotals{kScans, 0};
  in.expected[topic] = TopicExpectation{"usb", 10.0, {}};
  in.epoch_vehicle_ns = kT0;
  in.window_begin_ns = kT0;
  in.window_end_ns = kT0 + kScans * kPeriod;
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_EQ(r.topics.at(topic).published_twice, 0u);
  EXPECT_FALSE(r.invariants.at("stamps")) << "unflagged, 24 stamps 10-240 ms off";
  EXPECT_EQ(r.topics.at(topic).stamps_outside, 24u);
  in.unsynchronized[topic] = {{kT0 + 20 * kPeriod, kT0 + 47 * kPeriod}};
  r = check(in);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  EXPECT_EQ(r.topics.at(topic).published_twice, 0u);
  EXPECT_EQ(r.topics.at(topic).unaccounted, 0u);
  EXPECT_EQ(r.topics.at(topic).stamps_flagged, 24u);  // 240..10 ms off (the last one is exact)
}

// A GigE camera under a host clock step of -5 s for 6 s: its truth (host time) runs 5 s behind
// meanwhile. The frame made just before the step was undone arrived after it, 5.01 s after its
// acquisition by the host's clock; its stamp was slewed far off (flagged). Held to 1 s, its frame
// id matched nothing, and by its stamp it took another frame: "published twice" (rig chaos seed 9
// with drawn parameters). A frame id reaches across a host step of the campaign (its size, within
// 1 s), not over any distance up to the largest: a camera's ids begin again after a restart, and a
// frame 3 s after another of its id is its own, not that one (seed 4: "published twice (seq 248
// and 248)" with a reach of 1 s plus the largest step).
TEST(ChaosCheck, AFrameArrivingAcrossAHostStepsUndoIsItsUnitByFrameId) {
  const std::string topic = "/sensors/camera/cam/image_raw";
  constexpr int kFrames = 160;
  constexpr Nanos kStep = -5 * kSec, kStepAt = kT0 + 30 * kPeriod + 5'000'000, kStepFor = 6 * kSec;
  const auto host = [&](Nanos t) { return t >= kStepAt && t < kStepAt + kStepFor ? t + kStep : t; };
  Input in;
  truth::Log log, host_log;
  log.header = truth::Header{"cam", "camera", "fake", topic, "frame", "CLOCK_REALTIME"};
  host_log.header = truth::Header{"host", "host", "", "", "", "CLOCK_REALTIME"};
  host_log.faults.push_back(truth::FaultRecord{1, "host.clock_step", kStepAt, kStepAt + kStepFor, -1, "ms=-5000, back after the fault"});
  const int last_in_step = static_cast<int>((kStepAt + kStepFor - kT0 - 1) / kPeriod);
  for (int u = 0; u < kFrames; ++u) {
    const Nanos made = kT0 + u * kPeriod, acq = host(made);
    log.units.push_back(truth::UnitRecord{u, acq, acq, 1});
    log.parts.push_back(truth::PartRecord{static_cast<std::uint64_t>(u), u, acq, acq, acq, truth::Fate::kSent, 0});
    SampleRecord s;
    s.topic = topic;
    s.seq = static_cast<std::uint64_t>(u);
    s.acquisition_ns = acq;
    s.first_rx_ns = host(made + 10'000'000);
    if (u == last_in_step) {
      ASSERT_GT(s.first_rx_ns - acq, 5 * kSec) << "arrives after the undo";
      s.acquisition_ns = kT0 + 100 * kPeriod;  // slewed: another frame's time
    }
    if (u == 140) s.seq = 110;  // the camera's ids began again: frame 140 has frame 110's id
    s.publish_ns = s.first_rx_ns + 5'000'000;
    s.received_ns = s.publish_ns + 1'000'000;
    s.packets = 1;
    in.samples.push_back(s);
  }
  in.truths = {log, host_log};
  in.unsynchronized[topic] = {{kT0 + 50 * kPeriod, kT0 + 105 * kPeriod}};
  in.monitor[topic] = MonitorTotals{kFrames, 0};
  in.expected[topic] = TopicExpectation{"cam", 10.0, {}};
  in.epoch_vehicle_ns = kT0;
  in.window_begin_ns = kT0;
  in.window_end_ns = kT0 + kFrames * kPeriod;
  const Result r = check(in);
  EXPECT_EQ(r.topics.at(topic).published_twice, 0u) << result_text(r);
  EXPECT_EQ(r.topics.at(topic).unaccounted, 0u) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
}

TEST(ChaosCheck, AStarvedHealthyDeviceBreaksIsolation) {
  Input in = honest();
  in.expected[kTopic].rate_hz = 10.0;
  // Only 3 of 50 frames, and no fault touched the device: another device's fault starved it.
  in.samples.erase(in.samples.begin() + 3, in.samples.end());
  in.counted_lost[kTopic] = 47;
  in.monitor[kTopic] = MonitorTotals{3, 47};
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("isolation"));
  EXPECT_LT(r.topics.at(kTopic).healthy_rate_share, 0.1);
  // The same loss while a fault of its own was active is not an isolation failure.
  in.events.push_back(faults::FaultEvent{1, "lidar.restart", "front", 0.0, 5.0, {}});
  in.truths[0].faults.push_back(truth::FaultRecord{1, "lidar.restart", kT0, kT0 + 5 * 1'000'000'000LL, 0, ""});
  r = check(in);
  EXPECT_TRUE(r.invariants.at("isolation")) << result_text(r);
}

// A camera's own fault keeps it from being "healthy" until it is back (within its recovery bound),
// not for a fixed settle: how soon it is back is `recovery`'s to judge. Camera-only rig chaos broke
// isolation on cameras the driver reopened 1.1-2.5 s after their own camera.dies / camera.slow_open
// ended (seed 8 corner_rear_left 72.6 %, recovery held); the truth had no frame in that time.
TEST(ChaosCheck, ACamerasOwnFaultLastsForIsolationUntilItIsBack) {
  Input in = honest();
  in.truths[0].header.device_class = "camera";
  // camera.dies from 0.5 to 1.5 s; no frame is made until the driver reopened it at 3.0 s.
  for (int u = 5; u < 30; ++u)
    for (std::uint32_t p = 0; p < kParts; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
  in.samples.erase(in.samples.begin() + 5, in.samples.begin() + 30);
  in.monitor[kTopic] = MonitorTotals{kScans - 25, 0};
  in.events.push_back(faults::FaultEvent{1, "camera.dies", "front", 0.5, 1.0, {}});
  in.truths[0].faults.push_back(truth::FaultRecord{1, "camera.dies", kT0 + 5 * kPeriod, kT0 + 15 * kPeriod, -1, ""});
  Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_NEAR(r.topics.at(kTopic).healthy_rate_share, 1.0, 0.05);
  // The old judge: healthy again 1 s after the end (2.5 s), 23 frames of 28 expected (82 %).
  // The same silence with the fault on another camera: this one was starved, isolation breaks.
  in.events[0].device = "rear";
  r = check(in);
  EXPECT_FALSE(r.invariants.at("isolation")) << result_text(r);
  // Its own fault, and a later silence no fault explains (4.0-5.0 s): still broken.
  in.events[0].device = "front";
  in.samples.erase(in.samples.end() - 10, in.samples.end());
  in.monitor[kTopic] = MonitorTotals{kScans - 35, 10};
  in.counted_lost[kTopic] = 10;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("isolation")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
}

TEST(ChaosCheck, RecoveryIsTheFirstCompleteScanAfterTheFault) {
  Input in = honest();
  // lidar.stuck_azimuth from 1.0 to 1.5 s; the rig publishes nothing from 1.0 s until 2.8 s.
  in.events.push_back(faults::FaultEvent{1, "lidar.stuck_azimuth", "front", 1.0, 0.5, {}});
  in.truths[0].faults.push_back(truth::FaultRecord{1, "lidar.stuck_azimuth", kT0 + kPeriod * 10, kT0 + kPeriod * 15, 10, ""});
  auto slow = in;
  slow.samples.erase(slow.samples.begin() + 10, slow.samples.begin() + 28);
  slow.counted_lost[kTopic] = 18;
  slow.monitor[kTopic] = MonitorTotals{kScans - 18, 18};
  Result r = check(slow);
  EXPECT_FALSE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  auto fast = in;
  fast.samples.erase(fast.samples.begin() + 10, fast.samples.begin() + 16);
  fast.counted_lost[kTopic] = 6;
  fast.monitor[kTopic] = MonitorTotals{kScans - 6, 6};
  r = check(fast);
  EXPECT_TRUE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_NEAR(r.topics.at(kTopic).recovery_max_s, 0.1, 1e-6);
}

// A killed mock is judged from when its device was back, not from the plan's restart: the kill at
// 1.0 s with a 1 s restart, made 0.8 s late (its host truth line, written at the restart, says
// 2.8 s); the restarted LIDAR's first packet 0.4 s later, at 3.2 s. A rig that publishes that first
// scan recovered at once; from the plan's end (2.0 s) it broke, as the whole-rig campaign of stop 54
// did (seed 25, right). One that publishes nothing for 1.3 s after the packets resumed breaks still,
// and so does a mock that never came back (its line says so, its end stays the plan's).
TEST(ChaosCheck, RecoveryAfterAKilledMockIsJudgedFromWhenItsDeviceWasBack) {
  constexpr int kDeadFrom = 10, kBackAt = 32;
  auto killed = [&](Nanos restarted, const std::string& how) {
    Input in = honest();
    auto& units = in.truths[0].units;
    auto& parts = in.truths[0].parts;
    units.erase(units.begin() + kDeadFrom, units.begin() + kBackAt);  // the dead mock made nothing
    parts.erase(parts.begin() + kDeadFrom * kParts, parts.begin() + kBackAt * kParts);
    in.samples.erase(in.samples.begin() + kDeadFrom, in.samples.begin() + kBackAt);
    in.monitor[kTopic] = MonitorTotals{kScans - (kBackAt - kDeadFrom), 0};
    in.events.push_back(faults::FaultEvent{1, "host.kill_mock", "front", 1.0, 0.0, {{"restart_s", "1"}}});
    truth::Log host;
    host.header = truth::Header{"host", "host", "rig up", "", "", "CLOCK_REALTIME"};
    host.faults.push_back(truth::FaultRecord{1, "host.kill_mock", kT0 + 10 * kPeriod, restarted, -1, "front killed, " + how});
    in.truths.push_back(host);
    return in;
  };
  const Input late = killed(kT0 + 28 * kPeriod, "restarted 800 ms after its planned time");
  Result r = check(late);
  EXPECT_TRUE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("isolation")) << result_text(r);
  EXPECT_NEAR(r.topics.at(kTopic).recovery_max_s, 0.0, 1e-6) << "its first scan after its first packet, at once";

  Input slow = late;  // the rig publishes nothing until 4.5 s: 1.3 s after the packets resumed
  slow.samples.erase(slow.samples.begin() + kDeadFrom, slow.samples.begin() + kDeadFrom + 13);
  slow.counted_lost[kTopic] = 13;
  slow.monitor[kTopic] = MonitorTotals{kScans - (kBackAt - kDeadFrom) - 13, 13};
  r = check(slow);
  EXPECT_FALSE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);

  // Never back: no packet after the restart the plan made, and the line says so.
  Input gone = killed(kT0 + 20 * kPeriod, "not restarted: the rig stopped first");
  gone.truths[0].units.resize(kDeadFrom);
  gone.truths[0].parts.resize(kDeadFrom * kParts);
  gone.samples.resize(kDeadFrom);
  gone.monitor[kTopic] = MonitorTotals{kDeadFrom, 0};
  r = check(gone);
  EXPECT_FALSE(r.invariants.at("recovery")) << result_text(r);
}

// A host clock step of +1.5 s from 0.5 s, undone at 2.0 s: the host time from 2.0 to 3.5 s is read a
// second time, and its units are reconciled by number, not matched to samples. Recovery from the
// step is judged from where that time ends: from the fault's end, it found no complete sample
// within the LIDAR's second (rig chaos seed 9 with drawn parameters: front and left "not back" after a
// +2 s step whose scans were all complete).
TEST(ChaosCheck, RecoveryIntoDoubledHostTimeIsJudgedFromWhereItEnds) {
  Input in = honest();
  truth::Log host;
  host.header = truth::Header{"host", "host", "", "", "", "CLOCK_REALTIME"};
  host.faults.push_back(truth::FaultRecord{2, "host.clock_step", kT0 + 5 * kPeriod, kT0 + 20 * kPeriod, -1, "ms=1500, back after the fault"});
  in.truths.push_back(host);
  in.events.push_back(faults::FaultEvent{2, "host.clock_step", "", 0.5, 1.497, {{"ms", "1500"}}});  // undone 3 ms after its plan
  const Result r = check(in);
  EXPECT_TRUE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_NEAR(r.topics.at(kTopic).recovery_max_s, 0.0, 1e-6) << "back at 3.5 s, the first scan judged";
}

// A camera planned dead for the whole run has no recovery to judge, not even from its trigger
// LIDAR's faults (the whole-rig campaign reported stereo_right "not back" after an rpm change).
TEST(ChaosCheck, ACameraThatNeverAnswersHasNoRecoveryToJudge) {
  Input in = honest();
  const std::string cam = "/sensors/camera/stereo_right/image_raw";
  truth::Log dead;
  dead.header = truth::Header{"stereo_right", "camera", "arv-fake", cam, "frame", "camera ns"};
  dead.faults.push_back(truth::FaultRecord{1, "camera.never_answers", kT0, kT0 + kScans * kPeriod, -1, ""});
  in.truths.push_back(dead);
  in.expected[cam] = TopicExpectation{"stereo_right", 10.0, {"front"}};
  in.events.push_back(faults::FaultEvent{1, "camera.never_answers", "stereo_right", 0.0, 0.0, {}});  // as planned: no duration
  in.events.push_back(faults::FaultEvent{2, "lidar.rpm_change", "front", 1.0, 0.5, {}});
  in.truths[0].faults.push_back(truth::FaultRecord{2, "lidar.rpm_change", kT0 + kPeriod * 10, kT0 + kPeriod * 15, 10, ""});
  in.bounds.camera_recovery_s = 1.0;  // so that the deadline falls inside this 5 s window
  const Result r = check(in);
  EXPECT_TRUE(r.invariants.at("recovery")) << result_text(r);
  EXPECT_TRUE(r.all_held()) << result_text(r);
}

TEST(ChaosCheck, APlannedFaultNoMockRecordedIsReported) {
  Input in = honest();
  in.events.push_back(faults::FaultEvent{7, "lidar.reorder", "front", 2.0, 0.0, {{"n", "1"}, {"ms", "0"}}});
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("faults_injected"));
  EXPECT_EQ(r.faults_not_injected.at("lidar.reorder"), 1u);
  in.truths[0].faults.push_back(truth::FaultRecord{7, "lidar.reorder", kT0 + 2 * 1'000'000'000LL, kT0 + 2 * 1'000'000'000LL, 20, "n=1"});
  r = check(in);
  EXPECT_TRUE(r.invariants.at("faults_injected"));
  // Planned while its mock was killed (host.kill_mock, restarted 1 s later): it could not be injected.
  in.events.push_back(faults::FaultEvent{8, "host.kill_mock", "front", 3.0, 0.0, {{"restart_s", "1"}}});
  in.events.push_back(faults::FaultEvent{9, "lidar.stuck_azimuth", "front", 3.2, 0.5, {}});
  in.truths.push_back(truth::Log{});
  in.truths.back().header.device = "host";
  in.truths.back().faults.push_back(truth::FaultRecord{8, "host.kill_mock", kT0 + 3'000'000'000LL, kT0 + 4'000'000'000LL, -1, ""});
  r = check(in);
  EXPECT_TRUE(r.invariants.at("faults_injected")) << result_text(r);
  in.events.back().at_s = 4.4;  // it outlasts the dead time: it must be there
  EXPECT_FALSE(check(in).invariants.at("faults_injected"));
  EXPECT_EQ(r.faults.at("lidar.reorder"), 1u);
  // A restarted mock's line for a fault that fell while it was dead: in the record, not injected.
  in.events.push_back(faults::FaultEvent{10, "lidar.loss_burst", "front", 5.0, 0.0, {{"n", "10"}}});
  in.truths[0].faults.push_back(truth::FaultRecord{10, "lidar.loss_burst", kT0 + 5'000'000'000LL, kT0 + 5'000'000'000LL, -1,
                                                   std::string(truth::kNotInjected) + "its time came before this run began"});
  r = check(in);
  EXPECT_EQ(r.faults.count("lidar.loss_burst"), 0u) << result_text(r);
}

// 70 frames, one held 2.4 ms by the host: the p99 of so few is that frame, the median the body.

}  // namespace
}  // namespace sensor_rig::rig::chaos
