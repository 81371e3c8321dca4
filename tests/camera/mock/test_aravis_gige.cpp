// AravisSource over the real network path: arv-fake-gv-camera-0.8 processes on loopback
// addresses. Packet socket disabled + fixed socket buffer; lost packets -> incomplete frames
// counted, never returned; the fake killed mid-stream -> reported within 1 s; restarted -> resumes.
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "glib_log_counter.hpp"
#include "next_frame.hpp"
#include "open_at_once.hpp"
#include "test_addresses.hpp"

namespace sensor_rig::camera {
namespace {

// Four addresses this process holds alone among test processes (test_addresses.hpp) for its whole
// run: a concurrent test, or a run in another build dir, never shares a fake.
std::string address(int k) {
  static const sensor_rig::test::TestAddresses claim = sensor_rig::test::TestAddresses::take(20, 219, 4);
  return claim[static_cast<std::size_t>(k)];
}

class GigeFake : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    for (int k = 0; k < 2; ++k) {
      auto lease = LoopbackAddress::take(address(k), why);
      if (!lease) GTEST_SKIP() << why;
      addresses_.push_back(std::move(*lease));
    }
  }
  std::vector<LoopbackAddress> addresses_;  // on lo for the test, removed after it (also on failure)
  static SourceConfig cfg(const std::string& addr) {
    SourceConfig c;
    c.device = addr;
    c.format = PixelFormat::kBayerRG8;
    c.width = 640;
    c.height = 480;
    c.frame_rate = 20;
    return c;
  }
  static SourceConfig triggered_cfg(const std::string& addr) {
    SourceConfig c = cfg(addr);
    c.trigger = TriggerMode::kSoftware;
    return c;
  }
};

// Incomplete frames (the packet-loss test) are skipped: they are counted, never returned as frames.
Capture next_frame(FrameSource& s, int budget_ms = 3000) { return test::next_frame(s, budget_ms, /*skip_incomplete=*/true); }

TEST_F(GigeFake, StreamsOverLoopbackWithThePacketSocketDisabled) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  AravisSource src(cfg(o.address));
  src.open();
  int frames = 0;
  Nanos last = 0;
  for (int i = 0; i < 10; ++i) {
    auto c = next_frame(src);
    ASSERT_EQ(c.status, CaptureStatus::kFrame) << c.error;
    EXPECT_GT(c.frame.meta().device_ns, last);
    EXPECT_GT(c.frame.meta().packets, 0u);
    last = c.frame.meta().device_ns;
    ++frames;
  }
  const auto st = src.stats();
  EXPECT_EQ(st.completed, 10u);
  EXPECT_GT(src.details().packet_size, 0);
  src.close();
  fake.stop(500);
}

// Issue 27 item 4: the kernel caps the stream socket's SO_RCVBUF at net.core.rmem_max without a
// word. The source reads back what it was granted (a socket asking the same size: twice the
// request up to the cap, as the kernel reports it) against one frame's need; the host's sysctls are
// read, never changed.
TEST_F(GigeFake, TheGrantedSocketBufferIsReportedAgainstWhatAFrameNeeds) {
  std::int64_t rmem_max = 0;
  std::ifstream("/proc/sys/net/core/rmem_max") >> rmem_max;
  ASSERT_GT(rmem_max, 0);
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  const std::int64_t frame = 640 * 480;  // BayerRG8
  for (const std::int64_t asked : {std::int64_t{8} << 20, std::int64_t{200} << 10}) {
    SCOPED_TRACE(asked);
    auto c = cfg(o.address);
    c.socket_buffer_bytes = static_cast<int>(asked);
    AravisSource src(c);
    src.open();
    const auto st = src.stats();  // read back at open
    EXPECT_EQ(st.socket_buffer_granted, 2 * std::min(asked, rmem_max));
    EXPECT_EQ(st.socket_buffer_needed, 2 * frame);
    // 200 kB is short of a 300 kB frame whatever the host allows: the case the WARN is for.
    if (asked < frame) {
      EXPECT_LT(st.socket_buffer_granted, st.socket_buffer_needed);
    }
    // A frame comes through a buffer that holds one. One short of a frame may lose a packet of every
    // frame while the receiving thread waits for a core (a fresh clone's suite: no whole frame in 3 s
    // through 400 kB granted for 600 kB): the loss the WARN announces, not a failure of the source.
    if (st.socket_buffer_granted >= st.socket_buffer_needed) {
      EXPECT_EQ(next_frame(src).status, CaptureStatus::kFrame);
    }
    src.close();
  }
  fake.stop(500);
}

// The GigE fake (unlike the in-process one) gates its stream on TriggerSoftware in software
// trigger mode: no trigger, no frame; each trigger, one frame.
TEST_F(GigeFake, SoftwareTriggerModeGivesOneFramePerTriggerAndNoneWithout) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  AravisSource src(triggered_cfg(o.address));
  src.open();
  ASSERT_TRUE(src.is_open());
  EXPECT_EQ(src.feature("TriggerMode"), "On");
  EXPECT_EQ(src.feature("TriggerSource"), "Software");
  // Untriggered: silence (several frame periods at 20 Hz).
  const Nanos quiet_until = monotonic_now_ns() + 600'000'000;
  while (monotonic_now_ns() < quiet_until) EXPECT_NE(src.next(50).status, CaptureStatus::kFrame);
  EXPECT_EQ(src.stats().completed, 0u);
  // Each trigger gives one frame: whole (returned) or, when the loaded host drops a packet on
  // loopback, incomplete (counted) — one outcome per trigger, and nothing between triggers.
  const auto outcomes = [&src] { return src.stats().completed + src.stats().incomplete; };
  Nanos last = 0;
  for (int i = 0; i < 3; ++i) {
    const std::uint64_t before = outcomes();
    ASSERT_TRUE(src.trigger());
    const Nanos deadline = monotonic_now_ns() + 2'000'000'000;
    while (outcomes() == before && monotonic_now_ns() < deadline) {
      auto cap = src.next(50);
      if (cap.status != CaptureStatus::kFrame) continue;
      EXPECT_GT(cap.frame.meta().device_ns, last);
      last = cap.frame.meta().device_ns;
    }
    ASSERT_EQ(outcomes(), before + 1) << "trigger " << i << " gave no frame";
    const Nanos until = monotonic_now_ns() + 300'000'000;
    while (monotonic_now_ns() < until) EXPECT_NE(src.next(50).status, CaptureStatus::kFrame);
    EXPECT_EQ(outcomes(), before + 1) << "more than one frame for trigger " << i;
  }
  EXPECT_GE(src.stats().completed, 1u);
  src.close();
  fake.stop(500);
}

// Issue 27 item 1: a trigger never queues behind another access to the camera stuck in a GVCP
// timeout (here a feature read to a camera that stopped answering: the fake stopped with SIGSTOP;
// in the rig the exposure read or the PTP poll). It is refused at once, counted (trigger_busy),
// and the camera takes triggers again when it answers. Before, it waited for the read's retries.
TEST_F(GigeFake, ATriggerIsRefusedNotQueuedBehindAnAccessInAGvcpTimeout) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  AravisSource src(triggered_cfg(o.address));
  src.open();
  ASSERT_TRUE(src.trigger());
  // The write must still be in its retries when the trigger comes (now and then it was answered
  // before the stop took hold): an attempt where it was not is not this test's case, and repeated.
  bool held = false;
  bool taken = true;
  Nanos waited = 0;
  for (int attempt = 0; attempt < 3 && !held; ++attempt) {
    ASSERT_EQ(::kill(fake.pid(), SIGSTOP), 0);
    std::atomic<Nanos> written{0};
    std::thread writer([&] {
      try {  // a write (a read may come from Aravis' register cache) holds the camera through its GVCP retries
        src.set_feature("ExposureTimeAbs", "5000");
      } catch (const CameraError&) {  // the camera did not answer: what this test makes it do
      }
      written.store(monotonic_now_ns());
    });
    ::usleep(50'000);  // well inside the write's first GVCP timeout (500 ms)
    const Nanos t0 = monotonic_now_ns();
    taken = src.trigger();
    waited = monotonic_now_ns() - t0;
    ::kill(fake.pid(), SIGCONT);
    writer.join();
    held = written.load() > t0;
  }
  ASSERT_TRUE(held) << "the write was answered at once in every attempt";
  EXPECT_FALSE(taken);
  EXPECT_LT(waited, 30'000'000) << "a trigger waited " << waited / 1'000'000 << " ms behind the write";
  EXPECT_EQ(src.stats().trigger_busy, 1u);
  // The camera answers again: triggers are taken.
  bool again = false;
  for (int i = 0; i < 20 && !again; ++i) {
    again = src.trigger();
    if (!again) ::usleep(50'000);
  }
  EXPECT_TRUE(again);
  src.close();
  fake.stop(500);
}

// rig-fake-gige-camera (rig up's GigE mock): a triggered frame's reported exposure start (the
// fake's CLOCK_REALTIME at exposure, its device ticks) follows the trigger call within its 250 us
// grid, where Aravis's own fake waits for its 40 ms grid (median ~20 ms). Median, not every frame:
// a loaded host may delay the fake's process now and then. Its leader leaves after the exposure, as
// a real camera's (the clock mapping's model): every frame's first packet arrives >= ExposureTime
// after its stamp (the stock fake sends it after its pattern generator only, ~1-3 ms).
TEST_F(GigeFake, TriggerFollowingFakeExposesWithinAMillisecondOfTheTriggerAndSendsAfterTheExposure) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  o.program = RIG_FAKE_GIGE_CAMERA;
  auto fake = mock::start_gige_fake(o);
  SourceConfig c = triggered_cfg(o.address);
  c.exposure_us = 5000;
  AravisSource src(c);
  src.open();
  ASSERT_TRUE(src.is_open());
  std::vector<Nanos> delays;
  for (int i = 0; i < 12 && delays.size() < 8; ++i) {
    const Nanos called = vehicle_now_ns();
    ASSERT_TRUE(src.trigger());
    auto cap = next_frame(src, 2000);
    if (cap.status != CaptureStatus::kFrame) continue;  // a frame lost on loopback: the next trigger
    delays.push_back(cap.frame.meta().device_ns - called);
    // The same host clock (the fake's stamp is CLOCK_REALTIME): exposure end precedes the leader.
    EXPECT_GE(cap.frame.meta().first_rx_ns - cap.frame.meta().device_ns, 5'000'000) << "first packet before exposure end";
  }
  ASSERT_GE(delays.size(), 6u);
  std::sort(delays.begin(), delays.end());
  EXPECT_GE(delays.front(), -1'000) << "exposed before its trigger (the fake's clock is in us)";
  EXPECT_LE(delays[delays.size() / 2], 1'000'000) << "median trigger -> exposure " << delays[delays.size() / 2] << " ns";
  src.close();
  fake.stop(500);
}

// The mock stands for camera hardware: with realtime_priority every thread of the fake runs
// SCHED_FIFO (set before the fake starts its threads), so host load is not the "camera's" delay.
TEST_F(GigeFake, TriggerFollowingFakeRunsEveryThreadAtTheAskedRealtimePriority) {
  bool permitted = false;
  std::string why;
  std::thread([&] {
    const auto r = try_realtime_priority(7);
    permitted = r.applied;
    why = r.why_not;
  }).join();
  if (!permitted) GTEST_SKIP() << "SCHED_FIFO not permitted here: " << why;
  mock::GigeFakeOptions o;
  o.address = address(0);
  o.program = RIG_FAKE_GIGE_CAMERA;
  o.realtime_priority = 7;
  const auto argv = mock::gige_fake_command(o);
  ASSERT_NE(std::find(argv.begin(), argv.end(), "--realtime-priority"), argv.end());
  auto fake = mock::start_gige_fake(o);
  int threads = 0, fifo_7 = 0;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(fake.pid()) + "/task")) {
    const pid_t tid = std::stoi(task.path().filename().string());
    sched_param p{};
    ++threads;
    if (::sched_getscheduler(tid) == SCHED_FIFO && ::sched_getparam(tid, &p) == 0 && p.sched_priority == 7) ++fifo_7;
  }
  EXPECT_GE(threads, 2) << "the fake's GVCP/stream thread";
  EXPECT_EQ(fifo_7, threads);
  fake.stop(500);
}

TEST_F(GigeFake, LostPacketsGiveIncompleteFramesThatAreNeverReturned) {
  mock::GigeFakeOptions o;
  o.address = address(1);
  o.lost_packets_per_thousand = 30;  // 3 %: most 640x480 frames (~210 packets) lose one
  auto fake = mock::start_gige_fake(o);
  auto c = cfg(o.address);
  AravisSource src(c);
  src.open();
  int frames = 0;
  const Nanos deadline = monotonic_now_ns() + 3'000'000'000;
  while (monotonic_now_ns() < deadline && src.stats().incomplete < 3) {
    auto cap = src.next(100);
    if (cap.status != CaptureStatus::kFrame) continue;
    ++frames;
    EXPECT_EQ(cap.frame.data().size(), std::size_t{640} * 480);
  }
  const auto st = src.stats();
  EXPECT_GE(st.incomplete, 3u) << "completed " << st.completed;
  EXPECT_EQ(st.completed, static_cast<std::uint64_t>(frames));  // only whole frames came out
  EXPECT_GT(st.missing_packets + st.resent_packets, 0u);
  // Each incomplete frame counted by why: packets missing (or the frame's packets stopped coming).
  EXPECT_EQ(st.incomplete_missing_packets + st.incomplete_timeout + st.incomplete_other, st.incomplete);
  EXPECT_GE(st.incomplete_missing_packets + st.incomplete_timeout, 3u) << "other " << st.incomplete_other;
  src.close();
  fake.stop(500);
}

TEST_F(GigeFake, KilledFakeIsReportedWithin1sAndFramesResumeAfterRestart) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  AravisSource src(cfg(o.address));
  src.open();
  ASSERT_EQ(next_frame(src).status, CaptureStatus::kFrame);
  ::kill(fake.pid(), SIGKILL);
  const Nanos killed = monotonic_now_ns();
  (void)fake.stop(500);
  // What the driver does: no frame for 3 periods or control lost -> reported; at most 1 s.
  Nanos last_frame = killed;
  Nanos reported = 0;
  while (monotonic_now_ns() - killed < 3'000'000'000) {
    const auto c = src.next(50);
    if (c.status == CaptureStatus::kFrame) last_frame = monotonic_now_ns();
    if (c.status == CaptureStatus::kDisconnected || monotonic_now_ns() - last_frame > 300'000'000) {
      reported = monotonic_now_ns();
      break;
    }
  }
  ASSERT_NE(reported, 0);
  EXPECT_LT(reported - killed, 1'000'000'000);
  src.mark_lost();
  src.close();  // does not wait for the dead device
  EXPECT_LT(monotonic_now_ns() - reported, 500'000'000);
  auto again = mock::start_gige_fake(o);
  // Reopen as the driver does: retry until the fake answers.
  const Nanos deadline = monotonic_now_ns() + 5'000'000'000;
  bool reopened = false;
  while (!reopened && monotonic_now_ns() < deadline) {
    try {
      src.open();
      reopened = true;
    } catch (const CameraError&) {
      ::usleep(100'000);
    }
  }
  ASSERT_TRUE(reopened);
  EXPECT_LT(monotonic_now_ns() - killed, 3'000'000'000);  // restart to frames within 3 s
  EXPECT_EQ(next_frame(src).status, CaptureStatus::kFrame);
  src.close();
  again.stop(500);
}

// Hardware line trigger against the fake with Line1 and FallingEdge added to its GenICam (its
// own has Line0 and RisingEdge only). The fake sends frames in free run and on TriggerSoftware
// only: on a line it sends none, so what is checked is the features set, that nothing arrives and
// no TriggerSoftware reaches the device — and, TriggerMode set Off, that the stream was there.
TEST_F(GigeFake, LineTriggerSetsLineAndEdgeAndSendsNoSoftwareTrigger) {
  const std::string xml = mock::write_line_trigger_fake_genicam(address(1));
  mock::GigeFakeOptions o;
  o.address = address(0);
  o.genicam = xml;
  auto fake = mock::start_gige_fake(o);
  std::remove(xml.c_str());
  auto c = cfg(o.address);
  c.trigger = TriggerMode::kLine;
  c.trigger_line = "Line1";
  c.trigger_activation = "FallingEdge";
  AravisSource src(c);
  src.open();
  EXPECT_EQ(src.feature("TriggerSelector"), "FrameStart");
  EXPECT_EQ(src.feature("TriggerMode"), "On");
  EXPECT_EQ(src.feature("TriggerSource"), "Line1");
  EXPECT_EQ(src.feature("TriggerActivation"), "FallingEdge");
  EXPECT_FALSE(src.trigger());  // a line-triggered camera is never software-triggered
  EXPECT_EQ(src.feature("TriggerSoftwareTestRegister"), "0");
  const Nanos quiet_until = monotonic_now_ns() + 500'000'000;  // 10 periods at 20 Hz
  while (monotonic_now_ns() < quiet_until) EXPECT_NE(src.next(50).status, CaptureStatus::kFrame);
  EXPECT_EQ(src.stats().completed + src.stats().incomplete, 0u);
  src.set_feature("TriggerMode", "Off");
  EXPECT_EQ(next_frame(src).status, CaptureStatus::kFrame);
  src.close();
  fake.stop(500);
}

TEST_F(GigeFake, LineTriggerOnALineOrEdgeTheCameraLacksIsAnErrorAtOpen) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  const auto open_error = [&o](const std::string& line, const std::string& edge) -> std::string {
    auto c = cfg(o.address);
    c.trigger = TriggerMode::kLine;
    c.trigger_line = line;
    c.trigger_activation = edge;
    AravisSource src(c);
    try {
      src.open();
    } catch (const CameraError& e) {
      EXPECT_FALSE(src.is_open());
      return e.what();
    }
    return "opened";
  };
  EXPECT_NE(open_error("Line1", "RisingEdge").find("TriggerSource Line1: not offered (Line0, Software)"), std::string::npos)
      << open_error("Line1", "RisingEdge");
  EXPECT_NE(open_error("Line0", "FallingEdge").find("TriggerActivation FallingEdge"), std::string::npos)
      << open_error("Line0", "FallingEdge");
  EXPECT_EQ(open_error("Line0", "RisingEdge"), "opened");
  fake.stop(500);
}

// The watchdog's reopen of a live camera (marked lost: the old handles go on another thread, the
// device is left acquiring with its stream channel reset to port 0). The fake sends to the stream
// destination it reads when it sees control taken with acquisition on, and reads it again only
// after acquisition stops: a new controller that is slow to set its port (here held 250 ms after
// taking control, as a loaded host does) got nothing until AravisSource stopped acquisition
// first. Without that stop this fails on every reopen.
TEST_F(GigeFake, ALiveCameraReopenedAfterMarkLostStreamsAgain) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  const AravisDeviceOpener slow = [](const std::string& device) {
    void* d = open_aravis_network_device(device);  // control taken
    ::usleep(250'000);
    return d;
  };
  AravisSource src(cfg(o.address), slow);
  for (int round = 0; round < 3; ++round) {
    if (src.is_open()) src.mark_lost();
    src.open();
    const auto c = next_frame(src, 1500);
    ASSERT_EQ(c.status, CaptureStatus::kFrame) << "reopen " << round << ": " << c.error;
  }
  src.close();
  fake.stop(500);
}

// The mock rig's mix, opened as its capture threads do — all at once, each from its own thread:
// four GigE fakes and three in-process fakes. Aravis 0.8 corrupts its GenICam DOM when opens
// overlap; AravisSource opens one at a time. Every camera streams and GLib complains about
// nothing. Three passes; in the later two a GigE camera is also reopened twice as its
// watchdog does (marked lost: its old handles are released on another thread; opened again)
// while the others open. Without the one-at-a-time open this fails nearly every run (3-514 GLib
// criticals from arv_dom_*, sometimes SIGFPE or SIGSEGV); in-process fakes alone never showed it.
// Without the acquisition stop at open that reopen gave no frame for 3 s in 5 runs of 6 (the test
// above says why).
TEST_F(GigeFake, GigeAndInProcessCamerasOpenedAtOnceStreamWithoutGlibComplaints) {
  std::string why;
  std::vector<LoopbackAddress> more;
  for (int k = 2; k < 4; ++k) {
    auto lease = LoopbackAddress::take(address(k), why);
    if (!lease) GTEST_SKIP() << why;
    more.push_back(std::move(*lease));
  }
  const test::GlibLogCounter glib;
  std::vector<ChildProcess> fakes;
  std::vector<std::unique_ptr<AravisSource>> owned;
  for (int k = 0; k < 3; ++k) {
    auto c = cfg(std::string(mock::kFakePrefix) + "GIGEMIX" + std::to_string(k));
    owned.push_back(std::make_unique<AravisSource>(c, mock::inprocess_fake_opener()));
  }
  for (int k = 0; k < 4; ++k) {  // the last is the one reopened
    mock::GigeFakeOptions o;
    o.address = address(k);
    fakes.push_back(mock::start_gige_fake(o));
    owned.push_back(std::make_unique<AravisSource>(cfg(o.address)));
  }
  std::vector<AravisSource*> cams;
  for (auto& c : owned) cams.push_back(c.get());
  for (int pass = 0; pass < 3; ++pass) {  // each pass a chance for overlapping opens to show
    const auto outcome = test::open_at_once(cams, 2, /*reopens_of_last=*/pass == 0 ? 0 : 2);
    for (std::size_t i = 0; i < cams.size(); ++i) {
      EXPECT_EQ(outcome[i].error, "") << "pass " << pass << " camera " << i;
      EXPECT_EQ(outcome[i].frames, 2 * outcome[i].opens) << "pass " << pass << " camera " << i;
    }
    EXPECT_TRUE(glib.complaints().empty()) << glib.complaints().size() << " GLib complaints, first: " << glib.complaints().front();
    for (std::size_t i = 0; i + 1 < cams.size(); ++i) cams[i]->close();  // the last stays open: the next pass reopens it
  }
  for (auto& c : owned) c->close();
  for (auto& f : fakes) f.stop(500);
}

// PTP against the real network fake: its own GenICam XML (read from a running default fake, at
// test time) plus PtpEnable and PtpStatus (mock::write_ptp_fake_genicam: 0x8000 = 0 Disabled,
// 1 Slave, 2 Listening, other Faulty). The fake stamps each buffer with its host's CLOCK_REALTIME
// (g_get_real_time) at fill time, so "PTP time" is host UTC: with timescale tai the camera's TAI
// is that minus 37 s after conversion, with utc it is the receive time minus the transfer.

class GigePtpFake : public GigeFake {
 protected:
  void SetUp() override {
    GigeFake::SetUp();
    if (IsSkipped()) return;
    mock::GigeFakeOptions o;
    xml_path_ = mock::write_ptp_fake_genicam(address(1), gev_ieee1588());
    o.address = address(0);
    o.genicam = xml_path_;
    fake_ = mock::start_gige_fake(o);
  }
  void TearDown() override {
    fake_.stop(500);
    if (!xml_path_.empty()) std::remove(xml_path_.c_str());
  }
  [[nodiscard]] virtual bool gev_ieee1588() const { return false; }
  static SourceConfig ptp_cfg(bool tai) {
    auto c = cfg(address(0));
    c.ptp.enable = true;
    c.ptp.tai = tai;
    c.ptp.status_poll_ms = 100;
    return c;
  }
  std::string xml_path_;
  ChildProcess fake_;
};

// The fake's fill time to our receipt of a 640x480 frame on loopback: a few ms, 190-240 ms seen
// under load average 24 (2 runs of 15 failed at 150 ms). Far below the 37 s a wrong timescale
// makes, or device ticks.
constexpr Nanos kTransferBudgetNs = 500'000'000;

// The fake's realtime stamp, converted, against the receive time: never after it, at most the
// transfer budget before it.
void expect_vehicle_stamp(const Frame& f) {
  const auto& m = f.meta();
  EXPECT_EQ(m.domain, TimeDomain::kVehicle);
  EXPECT_LE(m.device_ns, m.complete_ns + 1'000'000);
  EXPECT_GT(m.device_ns, m.complete_ns - kTransferBudgetNs) << "stamp " << (m.complete_ns - m.device_ns) / 1000000 << " ms before receipt";
}

TEST_F(GigePtpFake, EnablesPtpAndStampsInUtcFromTaiOrUtc) {
  for (const bool tai : {true, false}) {
    SCOPED_TRACE(tai ? "timescale tai" : "timescale utc");
    const auto c = ptp_cfg(tai);
    AravisSource src(c);
    src.open();
    EXPECT_EQ(src.feature("PtpEnable"), "true");
    const auto p = src.ptp();
    EXPECT_TRUE(p.enabled);
    EXPECT_EQ(p.enable_feature, "PtpEnable");
    EXPECT_EQ(p.status, "Slave");
    EXPECT_TRUE(p.locked);
    for (int i = 0; i < 3; ++i) {
      auto cap = next_frame(src);
      ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
      if (tai) {
        // The fake's clock is UTC: read as TAI it converts to 37 s before the receive time.
        auto m = cap.frame.meta();
        EXPECT_EQ(m.domain, TimeDomain::kVehicle);
        m.device_ns += 37'000'000'000;
        EXPECT_LE(m.device_ns, m.complete_ns + 1'000'000);
        EXPECT_GT(m.device_ns, m.complete_ns - kTransferBudgetNs);
      } else {
        expect_vehicle_stamp(cap.frame);
      }
    }
    src.close();
  }
}

TEST_F(GigePtpFake, FaultyStatusIsResetAndUnlockedFramesKeepDeviceTicks) {
  AravisSource src(ptp_cfg(false));
  src.open();
  ASSERT_TRUE(src.ptp().locked);
  ASSERT_EQ(next_frame(src).frame.meta().domain, TimeDomain::kVehicle);
  // Listening (not locked, not reset): device ticks again, within a few polls.
  src.set_feature("PtpTestRegister", "2");
  Nanos deadline = monotonic_now_ns() + 2'000'000'000;
  while (src.ptp().locked && monotonic_now_ns() < deadline) ::usleep(20'000);
  EXPECT_EQ(src.ptp().status, "Listening");
  ASSERT_FALSE(src.ptp().locked);
  (void)next_frame(src);  // a frame that may have been in flight at the change
  auto cap = next_frame(src);
  ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
  EXPECT_EQ(cap.frame.meta().domain, TimeDomain::kDeviceTicks);
  cap.frame.reset();
  EXPECT_EQ(src.ptp().resets, 0u);
  // Faulty: disabled and enabled by the status thread, locked again.
  src.set_feature("PtpTestRegister", "7");
  deadline = monotonic_now_ns() + 2'000'000'000;
  while (src.ptp().resets == 0 && monotonic_now_ns() < deadline) ::usleep(20'000);
  const auto p = src.ptp();
  EXPECT_EQ(p.resets, 1u) << p.error;
  EXPECT_EQ(p.status, "Slave");
  EXPECT_TRUE(p.locked);
  EXPECT_EQ(src.feature("PtpTestRegister"), "1");
  EXPECT_GT(p.polls, 2u);
  EXPECT_GT(p.poll_max_us, 0);
  RecordProperty("ptp_polls", static_cast<int>(p.polls));
  RecordProperty("ptp_poll_max_us", static_cast<int>(p.poll_max_us));
  (void)next_frame(src);
  cap = next_frame(src);
  ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
  expect_vehicle_stamp(cap.frame);
  cap.frame.reset();
  src.close();
}

// A servo still Faulty after the enable at open (bits 8..31 of the fake's register survive an
// enable, not a disable): disabled and enabled once, as camera_aravis2 does, then Slave. The status
// is read after PtpDataSetLatch.
TEST_F(GigePtpFake, FaultyAfterTheEnableAtOpenIsResetOnceAndLocks) {
  {
    AravisSource before(cfg(address(0)));  // no PTP: just puts the fault in
    before.open();
    before.set_feature("PtpTestRegister", "256");
    before.close();
  }
  AravisSource src(ptp_cfg(false));
  src.open();
  const auto p = src.ptp();
  EXPECT_EQ(p.resets, 1u) << p.error;
  EXPECT_EQ(p.status, "Slave");
  EXPECT_TRUE(p.locked);
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(src.feature("PtpTestRegister"), "1");
  EXPECT_EQ(src.feature("PtpLatchTestRegister"), "1");
  auto cap = next_frame(src);
  ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
  expect_vehicle_stamp(cap.frame);
  cap.frame.reset();
  src.close();
}

TEST_F(GigePtpFake, PtpOffInTheConfigKeepsDeviceTicksAndLeavesPtpDisabled) {
  AravisSource src(cfg(address(0)));
  src.open();
  EXPECT_FALSE(src.ptp().enabled);
  EXPECT_EQ(src.feature("PtpEnable"), "false");
  EXPECT_EQ(src.feature("PtpStatus"), "Disabled");
  auto cap = next_frame(src);
  ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
  EXPECT_EQ(cap.frame.meta().domain, TimeDomain::kDeviceTicks);
  cap.frame.reset();
  src.close();
}

// Older cameras: GevIEEE1588 / GevIEEE1588Status (/ GevIEEE1588DataSetLatch), the same fake
// registers under those names.
class GigeGevIeee1588Fake : public GigePtpFake {
 protected:
  [[nodiscard]] bool gev_ieee1588() const override { return true; }
};

TEST_F(GigeGevIeee1588Fake, EnablesGevIEEE1588AndResetsAFaultyStatus) {
  AravisSource src(ptp_cfg(true));
  src.open();
  EXPECT_EQ(src.feature("GevIEEE1588"), "true");
  EXPECT_EQ(src.feature("PtpLatchTestRegister"), "1");
  auto p = src.ptp();
  EXPECT_EQ(p.enable_feature, "GevIEEE1588");
  EXPECT_EQ(p.status, "Slave");
  EXPECT_TRUE(p.locked);
  auto cap = next_frame(src);
  ASSERT_EQ(cap.status, CaptureStatus::kFrame) << cap.error;
  EXPECT_EQ(cap.frame.meta().domain, TimeDomain::kVehicle);
  cap.frame.reset();
  // Faulty while running: the status thread disables and enables GevIEEE1588.
  src.set_feature("PtpTestRegister", "7");
  const Nanos deadline = monotonic_now_ns() + 2'000'000'000;
  while (src.ptp().resets == 0 && monotonic_now_ns() < deadline) ::usleep(20'000);
  p = src.ptp();
  EXPECT_EQ(p.resets, 1u) << p.error;
  EXPECT_EQ(p.status, "Slave");
  EXPECT_EQ(src.feature("PtpTestRegister"), "1");
  src.close();
}

TEST_F(GigeFake, PtpEnabledOnACameraWithoutPtpFeaturesIsAnErrorAtOpen) {
  mock::GigeFakeOptions o;
  o.address = address(0);
  auto fake = mock::start_gige_fake(o);
  auto c = cfg(o.address);
  c.ptp.enable = true;
  AravisSource src(c);
  try {
    src.open();
    ADD_FAILURE() << "opened";
  } catch (const CameraError& e) {
    EXPECT_NE(std::string(e.what()).find("no PtpEnable or GevIEEE1588"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(src.is_open());
  fake.stop(500);
}

}  // namespace
}  // namespace sensor_rig::camera
