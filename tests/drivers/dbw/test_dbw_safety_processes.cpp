// Issue 9's defects across real processes: the real `rig dbw bridge`, `rig mock paravan` (bus log)
// and several `rig dbw send` processes on one DDS domain (passed with --domain). In turn:
//  1. a second sender's disable (its own, lower seq) disengages the first sender's engagement, and
//     the first, still holding enable, does not re-engage;
//  2. a bridge killed and restarted under a sender that holds enable stays disengaged;
//  3. a sender whose clock is 5 s behind (--clock-offset) cannot engage, but its disable counts;
//  4. SIGTERM while engaged: the bridge's last command frames on the bus are neutral.
// Assertions on rt/vehicle/dbw/status and on the mock's bus log, decoded with the protocol.
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "dbw_processes.hpp"
#include "wait_bounds.hpp"
#include "dbw_test_data.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"

namespace dbw = sensor_rig::dbw;
namespace msg = sensor_rig::msg;
namespace dds = sensor_rig::dds;
using sensor_rig::Nanos;
using sensor_rig::kMs;
using sensor_rig::vehicle_now_ns;

namespace {

struct Transition {
  Nanos t = 0;
  int state = 0;
  std::string reason;
};

// The test's view of the bridge: every status transition.
class StatusWatch {
 public:
  explicit StatusWatch(int domain)
      : participant_(sensor_rig::drivers::domain_config(domain)), topic_(participant_, sensor_rig::drivers::kStatusTopic, deep()),
        reader_(participant_, topic_, deep()) {}
  void poll(int wait_ms) {
    reader_.wait(wait_ms);
    reader_.take(
        [this](const msg::DbwStatus& s, const dds_sample_info_t&) {
          engaged = s.state == 1;
          const std::string event = s.event;
          if (event == "transition") transitions.push_back({msg::from_time(s.header.stamp), s.state, s.event_reason});
          if (event != "periodic") events += event + ":" + std::string(s.event_reason) + " ";
        },
        256);
  }
  // The bridge's status writer matched (it is up and on the domain).
  bool wait_for_bridge(int ms) { return reader_.wait_for_writers(1, ms); }
  // Polls until `pred` or `ms` passed; returns pred().
  template <class P>
  bool wait(int ms, P pred) {
    const Nanos end = vehicle_now_ns() + ms * kMs;
    while (!pred() && vehicle_now_ns() < end) poll(10);
    return pred();
  }
  [[nodiscard]] const Transition* first_after(Nanos t, int state) const {
    for (const auto& tr : transitions) {
      if (tr.t >= t && tr.state == state) return &tr;
    }
    return nullptr;
  }
  std::vector<Transition> transitions;
  std::string events;  // every non-periodic status event, for failure messages
  bool engaged = false;

 private:
  static dds::QosSpec deep() {
    dds::QosSpec q;
    q.depth = 256;
    return q;
  }
  dds::Participant participant_;
  dds::Topic<msg::DbwStatus> topic_;
  dds::Reader<msg::DbwStatus> reader_;
};

struct PuFrame {
  Nanos t = 0;
  std::string role;
  double enable = -1;
  bool neutral = true;  // every mapped value zero
};

std::vector<PuFrame> pu_frames(const std::string& path, const dbw::Protocol& p) {
  std::vector<PuFrame> out;
  std::ifstream in(path);
  dbw::can::CandumpReader reader(in);
  dbw::can::LogRecord rec;
  while (reader.next(rec)) {
    for (const auto& rm : p.tx_messages()) {
      if (!rm.matches(rec.frame) || rm.role == "heartbeat") continue;
      PuFrame f{rec.stamp, rm.role, -1, true};
      for (const auto& [role, sig] : rm.signals) {
        const double v = dbw::Protocol::value(rm, role, rec.frame).value_or(-1.0);
        if (role == "enable") f.enable = v;
        f.neutral = f.neutral && v == 0.0;
      }
      out.push_back(f);
    }
  }
  return out;
}

// PU command frames in [from, to) that are not neutral.
int active_frames(const std::vector<PuFrame>& frames, Nanos from, Nanos to) {
  int n = 0;
  for (const auto& f : frames) n += f.t >= from && f.t < to && !f.neutral ? 1 : 0;
  return n;
}

TEST(DbwSafetyProcesses, WritersRestartClockShiftAndSigterm) {
  dbw::test::RigProcesses rig("dbw_safety", dbw::test::DomainBy::kFlag);
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
  const std::string dom = std::to_string(rig.domain());
  const auto protocol = dbw::Protocol::load((dbw::test::source_dir() / "config/dbw/paravan_ref.yaml").string());
  auto send = [&](const std::string& name, bool enable, double seconds, double clock_offset = 0.0) {
    std::vector<std::string> a{"dbw", "send", "--domain", dom, "--steer", "0.05", "--throttle", "0.2", "--rate", "100",
                               "--duration", std::to_string(seconds), "--clock-offset", std::to_string(clock_offset)};
    if (enable) a.push_back("--enable");
    return rig.start(name, a);
  };
  auto bridge = [&](const std::string& name) {
    return rig.start(name, {"dbw", "bridge", "--domain", dom, "--transport", rig.bus(), "--duration", "60"});
  };

  StatusWatch st(rig.domain());
  const pid_t mock = rig.start_mock({"--duration", "60"});
  ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
  pid_t bridge_a = bridge("bridge_a");
  // A sender's first sample (enable false, then true: the edge) must reach a running bridge.
  ASSERT_TRUE(st.wait_for_bridge(sensor_rig::test::kDiscoveryMs)) << "bridge not discovered";

  // 1. Sender 1 engages and holds enable; sender 2 (seq from 1) disables.
  const pid_t s1 = send("s1", true, 3.0);
  ASSERT_TRUE(st.wait(6000, [&] { return st.engaged; })) << "sender 1 did not engage";
  const Nanos s2_start = vehicle_now_ns();
  const pid_t s2 = send("s2", false, 0.3);
  ASSERT_TRUE(st.wait(3000, [&] { return st.first_after(s2_start, 0) != nullptr; })) << "sender 2's disable was ignored";
  const Transition d1 = *st.first_after(s2_start, 0);
  EXPECT_EQ(d1.reason, "enable_released");
  EXPECT_EQ(rig.wait_exit(s2, 5000), 0);
  EXPECT_EQ(rig.wait_exit(s1, 5000), 0);  // held enable until its end
  st.poll(50);
  EXPECT_EQ(st.first_after(d1.t + 1, 1), nullptr) << "sender 1 re-engaged without a new edge";

  // 2. Sender 3 engages; the bridge is killed and restarted under it.
  const Nanos s3_start = vehicle_now_ns();
  const pid_t s3 = send("s3", true, 4.0);
  ASSERT_TRUE(st.wait(4000, [&] { return st.first_after(s3_start, 1) != nullptr; })) << "sender 3 did not engage; bridge events: " << st.events;
  ::kill(bridge_a, SIGKILL);
  rig.wait_exit(bridge_a, 2000);
  const Nanos restart = vehicle_now_ns();
  const pid_t bridge_b = bridge("bridge_b");
  EXPECT_EQ(rig.wait_exit(s3, 6000), 0);  // enable held throughout
  const Nanos s3_end = vehicle_now_ns();
  st.poll(50);
  EXPECT_EQ(st.first_after(restart, 1), nullptr) << "the restarted bridge engaged without an edge";

  // 3. A sender 5 s behind cannot engage; after sender 5 engages, that sender's disable counts.
  const Nanos s4_start = vehicle_now_ns();
  const pid_t s4 = send("s4", true, 1.0, -5.0);
  EXPECT_EQ(rig.wait_exit(s4, 5000), 0);
  st.poll(50);
  EXPECT_EQ(st.first_after(s4_start, 1), nullptr) << "commands stamped 5 s in the past engaged";
  const Nanos s5_start = vehicle_now_ns();
  const pid_t s5 = send("s5", true, 3.0);
  ASSERT_TRUE(st.wait(4000, [&] { return st.first_after(s5_start, 1) != nullptr; })) << "sender 5 did not engage; bridge events: " << st.events;
  const Nanos s6_start = vehicle_now_ns();
  const pid_t s6 = send("s6", false, 0.3, -5.0);
  ASSERT_TRUE(st.wait(3000, [&] { return st.first_after(s6_start, 0) != nullptr; })) << "a late clock's disable was ignored";
  EXPECT_EQ(st.first_after(s6_start, 0)->reason, "enable_released");
  EXPECT_EQ(rig.wait_exit(s6, 5000), 0);
  EXPECT_EQ(rig.wait_exit(s5, 5000), 0);

  // 4. Sender 7 engages; SIGTERM to the bridge while engaged.
  const Nanos s7_start = vehicle_now_ns();
  const pid_t s7 = send("s7", true, 5.0);
  ASSERT_TRUE(st.wait(4000, [&] { return st.first_after(s7_start, 1) != nullptr; })) << "sender 7 did not engage; bridge events: " << st.events;
  st.wait(300, [] { return false; });
  ::kill(bridge_b, SIGTERM);
  const Nanos term = vehicle_now_ns();
  EXPECT_EQ(rig.wait_exit(bridge_b, 5000), 0) << rig.output("bridge_b");
  ::kill(s7, SIGINT);
  rig.wait_exit(s7, 5000);
  EXPECT_EQ(rig.stop(mock), 0);
  EXPECT_NE(rig.output("bridge_b").find("\"neutral_sets_on_stop\":3"), std::string::npos);

  const auto frames = pu_frames(rig.bus_log(), protocol);
  ASSERT_FALSE(frames.empty());
  // Between sender 2's disable and sender 3's engagement: neutral only (sender 1 held enable).
  const Transition* e3 = st.first_after(s3_start, 1);
  ASSERT_NE(e3, nullptr);
  EXPECT_EQ(active_frames(frames, d1.t + 1, e3->t), 0);
  // From the restart to the end of sender 3 (enable held): neutral only.
  EXPECT_EQ(active_frames(frames, restart, s3_end), 0);
  // The clock-shifted sender: nothing active while it ran.
  EXPECT_EQ(active_frames(frames, s4_start, s5_start), 0);
  // SIGTERM: the engagement reached the bus, and the bridge's last command frames are neutral.
  EXPECT_GT(active_frames(frames, s7_start, term), 0);
  int neutral_after_term = 0;
  for (const auto& f : frames) {
    if (f.t >= term) neutral_after_term += f.neutral ? 1 : 0;
  }
  EXPECT_GE(neutral_after_term, 2 * 3) << "neutral frame sets after SIGTERM (steering + longitudinal, 3 periods)";
  EXPECT_TRUE(frames.back().neutral) << "an active frame was the last on the bus";
}

}  // namespace
