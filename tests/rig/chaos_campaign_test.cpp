// `rig chaos` on the whole mock rig (three LIDARs, seven cameras, drive-by-wire) with a fixed seed:
// every fault kind the mocks inject occurs, every mock's truth is held against what the rig
// published, and the verdict is what docs/faults.md says. The real `rig` in its own processes.
//
// Invariants that today's drivers still break are listed below, per device class, with the issue that
// fixes them: the test fails on any other broken invariant (a regression) and prints the listed ones
// that broke and those that held (a fix lands with its entry removed from the list).
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <thread>
#include <tuple>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "dds_domain_lease.hpp"
#include "fake_tc.hpp"
#include "rig_cli.hpp"
#include "rig_process.hpp"
#include "test_data.hpp"

namespace sensor_rig {
namespace {

// (invariant, device class) -> the open issue whose defects break it today.
// Stop 45: every other invariant held on every device in both ten-minute campaigns (seeds 1 and 2,
// after their fixes) and in this campaign's runs (CI's log of stop 44: all "held this run"), so the
// LIDAR entries (accounted, no_phantom_loss, stamps, monitor_agrees, recovery, isolation, fused) and
// the camera ones but stamps and isolation went: a break of any of them fails this test again.
// Stop 46: camera `stamps` went too. Its breaks (1.147 and 1.243 ms for consecutive frames) were a
// free-running GigE camera whose receiving thread, at normal priority, took its leaders p50 4 ms
// late, its clock mapping resting on a late floor and said locked: the mock rig's free-running
// cameras now run real-time and such a mapping flags its stamps (FrameStamp::floor_unseen); 8 runs
// since held it.
// Stop 49: camera `isolation` went, the last entry. Its breaks (the LIDAR-triggered stereo pair at
// 93.6-94.8 % while no fault touched it, stops 43 and 45) were not traced; the likeliest cause is the
// one e833f87 fixed: a frame matched to the trigger call a period before its own takes the previous
// frame's stamp. 6 runs since held it, every camera at 99-101 % of its rate (the shares are printed
// below). The list stays for a defect found and not yet fixed.
// Stop 52: random faults draw their parameters from their kinds' ranges (docs/faults.md); this
// campaign keeps each kind's defaults (--default-params), the plan every stop since 45 held. Drawn,
// seed 25 still breaks (issue 25's note): a Pandar40P's turn count after a 0.74 s frozen encoder
// (one scan unaccounted), and free-running cameras' frames exposed just before a host clock step
// forward stamped after it (2 s late, matched to no frame; 1 run in 3). The ten-minute campaigns
// (BENCHMARKS.md) run with the draws.
const std::map<std::pair<std::string, std::string>, std::string> kKnownBroken = {};

std::string class_of(const std::string& topic) {
  if (topic.rfind("/sensors/lidar/", 0) == 0) return "lidar";
  if (topic.rfind("/sensors/camera/", 0) == 0) return "camera";
  return "other";
}

// The kinds `rig chaos --help` says the mocks inject.
std::set<std::string> injected_kinds() {
  const auto help = test::run_rig("chaos --help");
  std::set<std::string> kinds;
  std::istringstream in(help.out);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("  ", 0) != 0) continue;
    const auto end = line.find_first_of(" :", 2);
    const std::string k = line.substr(2, end - 2);
    if (k.find('.') != std::string::npos && k.find(' ') == std::string::npos) kinds.insert(k);
  }
  return kinds;
}

// Refused before anything starts (exit 2, the reason said): a real device in the config, a spec that
// is wrong, a kind no mock injects.
TEST(ChaosCampaign, BadCampaignsAreRefusedWithTheReason) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string real = dir.write("real.yaml",
                                     "rig: {name: real}\nlidars:\n  - {name: roof, model: VLP-16, port: 2368}\n");
  auto r = test::run_rig("chaos " + real + " --duration 10");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("lidar 'roof' is a real device"), std::string::npos) << r.err;
  const std::string mock = (test::source_dir() / "config/mock_rig.yaml").string();
  for (const auto& [spec, says] : std::vector<std::pair<std::string, std::string>>{
           {"lidar.reordr", "unknown fault kind 'lidar.reordr'"},
           {"lidar.reorder:speed=2", "takes no parameter 'speed'"}}) {
    r = test::run_rig("chaos " + mock + " --duration 10 --faults '" + spec + "'");
    EXPECT_EQ(r.code, 2) << spec;
    EXPECT_NE(r.err.find(says), std::string::npos) << spec << ": " << r.err;
  }
}

TEST(ChaosCampaign, EveryKindOnTheWholeMockRigIsJudgedAgainstTheTruth) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  const std::set<std::string> kinds = injected_kinds();
  ASSERT_GE(kinds.size(), 20u) << "rig chaos --help lists the injected kinds";
  test::TempDir dir;
  const std::string out = (dir.path / "campaign").string();
  const auto run = test::run_rig("chaos " + (test::source_dir() / "config/mock_rig.yaml").string() +
                                 " --duration 45 --seed 25 --rate 6 --default-params --json --out " + out);
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  ASSERT_FALSE(run.out.empty()) << "no verdict on stdout:\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;

  // The campaign did what it planned: every kind occurred and every planned fault is in a truth record.
  for (const auto& k : kinds) EXPECT_GE(j["faults"].value(k, 0), 1) << k << " never injected";
  // A broken invariant's examples, put before run.err: CI keeps only part of a long log.
  const auto examples_of = [&](const std::string& invariant, const std::string& cls) {
    std::string what;
    for (const auto& e : j["examples"])
      if (e["invariant"] == invariant && (cls.empty() || class_of(e["topic"].get<std::string>()) == cls))
        what += "  " + e["topic"].get<std::string>() + ": " + e.value("what", "") + "\n";
    return what;
  };
  EXPECT_EQ(j["invariants"]["faults_injected"], "held") << examples_of("faults_injected", "") << "the campaign's stderr:\n" << run.err;

  // Every device was judged: each LIDAR and camera topic, with units made (but a never-answering camera).
  std::set<std::string> silent;
  std::ifstream plan(out + "/plan.jsonl");
  for (std::string line; std::getline(plan, line);) {
    const auto e = nlohmann::json::parse(line);
    if (e.value("kind", "") == "camera.never_answers") silent.insert(e.value("device", ""));
  }
  const auto& topics = j["topics"];
  EXPECT_EQ(topics.size(), 12u) << "3 LIDARs, the fused cloud, 7 cameras and /vehicle/state";
  // A camera that never answers no longer silences its trigger partner (issue 27 item 1).
  for (const auto& [topic, t] : topics.items()) {
    if (silent.contains(t.value("device", ""))) continue;
    EXPECT_GT(t["sent"].get<std::uint64_t>(), 0u) << topic;
  }

  // The verdict: broken invariants per device class, against the list of known defects.
  std::set<std::pair<std::string, std::string>> broken;
  for (const auto& e : j["examples"]) broken.insert({e["invariant"].get<std::string>(), class_of(e["topic"].get<std::string>())});
  for (const auto& b : broken) {
    const auto known = kKnownBroken.find(b);
    if (known != kKnownBroken.end()) {
      // With its examples: a known defect that shows up only now and then is traced from the log.
      std::printf("known defect (issue %s): %s on %s\n%s", known->second.c_str(), b.first.c_str(), b.second.c_str(),
                  examples_of(b.first, b.second).c_str());
      continue;
    }
    ADD_FAILURE() << b.first << " broken on " << b.second << " (not a known defect):\n" << examples_of(b.first, b.second)
                  << "the campaign's stderr:\n" << run.err;
  }
  for (const auto& [known, issue] : kKnownBroken)
    if (!broken.contains(known)) std::printf("held this run (issue %s): %s on %s\n", issue.c_str(), known.first.c_str(), known.second.c_str());
  // Each device's share of its rate while no fault touched it, the margin of `isolation` (bound 95 %).
  std::string shares;
  for (const auto& [topic, t] : topics.items())
    if (t.contains("healthy_rate_share")) shares += " " + t.value("device", topic) + " " + std::to_string(static_cast<int>(100 * t["healthy_rate_share"].get<double>() + 0.5)) + "%";
  std::printf("healthy rate shares:%s\n", shares.c_str());
  // Whatever went wrong around the campaign itself (a rig that did not stop in time, a mock that did
  // not start), printed for whoever reads the log.
  if (j.contains("campaign_errors")) std::printf("campaign errors: %s\n", j["campaign_errors"].dump().c_str());
}

// Drive-by-wire alone, every dbw kind and the mock-process faults at fixed times: each feedback frame
// the mock ECU made is a /vehicle/state sample or counted lost by the bridge, and every invariant
// holds. The stall comes last on purpose: the thread that restarted the killed ECU used to end after
// it, and PR_SET_PDEATHSIG then stopped the restarted ECU for the rest of the run.
TEST(ChaosCampaign, DriveByWireHoldsEveryInvariantUnderItsFaults) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  // A domain of its own: on the whole rig's domain 0 a /vehicle/state writer of the campaign before
  // (a process still in its DDS lease) was judged as this one's ("matches no can_frame").
  const std::string domain = std::to_string(test::lease_dds_domain());
  const std::string config = dir.write("dbw.yaml", "rig:\n  name: dbw-only\n  dds: {domain: " + domain + ", profile: " + src +
                                                      "/config/cyclonedds/loopback.xml}\n  diagnostics_period_ms: 500\n"
                                                      "dbw:\n  protocol: " + src + "/config/dbw/paravan_ref.yaml\n"
                                                      "  bus: " + (dir.path / "bus.sock").string() + "\n  mock_ecu: true\n"
                                                      "  command_source: {rate_hz: 50, steer_rad: 0.05, throttle: 0.2, gear: 4}\n");
  const auto run = test::run_rig("chaos " + config + " --duration 22 --seed 4 --json --faults '"
                                 "host.kill_mock@1>paravan;dbw.loss:p=0.2@3+2;dbw.bad_crc@6+0.5;dbw.stuck_counter@8+0.5;"
                                 "dbw.bus_off@10+0.3;dbw.override@11.5+0.5;dbw.ecu_fault@13+0.5;dbw.no_status@14.5+0.3;"
                                 "host.stall_mock:ms=300@16>paravan' --out " + (dir.path / "kept").string());
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_json = [](const std::string& out) {
    const auto last_nl = out.find_last_of('\n', out.size() - 2);
    return nlohmann::json::parse(out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  };
  const auto j = last_json(run.out);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  // The kept campaign judged again (rig chaos --judge): the same verdict, nothing run.
  const auto again = test::run_rig("chaos --judge " + (dir.path / "kept").string() + " --json");
  EXPECT_EQ(again.code, run.code) << again.err;
  EXPECT_EQ(last_json(again.out), j) << again.err;
  const auto& t = j["topics"]["/vehicle/state"];
  ASSERT_TRUE(t.is_object()) << run.out;
  EXPECT_GT(t["sent"].get<std::uint64_t>(), 1500u) << "100 Hz for ~20 s";
  EXPECT_GT(t["counted_lost"].get<std::uint64_t>(), 50u) << "the losses, bad CRCs and frozen counters were counted";
  EXPECT_EQ(t["unaccounted"].get<std::uint64_t>(), 0u);
  for (const auto& [name, verdict] : j["invariants"].items()) EXPECT_EQ(verdict, "held") << name << "\n" << run.err;
  EXPECT_EQ(run.code, 0) << run.err;
}

// The three mock LIDARs while the host's CLOCK_REALTIME is stepped back 500 ms for 5 s. The
// Velodyne keeps its GPS time; the PTP-synced Ouster and Hesai disagree with the stepped host, their
// stamps follow the host (mapped) and are held and slewed: up to 500 ms off the truth. Before, they
// went out as synchronized ("stamps" broken: -100 ms ... -500 ms, unflagged); now the LIDAR node
// flags the topic unsynchronized while its stamps knowingly differ from the sensor's time, and
// every other invariant holds (issue 26).
TEST(ChaosCampaign, AHostClockStepLeavesNoLidarStampOffUnflagged) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  std::string rig = test::read_text(test::source_dir() / "config/mock_rig.yaml");
  rig = rig.substr(0, rig.find("\nfusion:"));  // the three LIDARs: fusion, dbw and cameras apart
  rig.replace(rig.find("profile: cyclonedds/"), std::string("profile: cyclonedds/").size(), "profile: " + src + "/config/cyclonedds/");
  rig.replace(rig.find("domain: 0"), std::string("domain: 0").size(), "domain: " + std::to_string(test::lease_dds_domain()));
  const std::string config = dir.write("lidars.yaml", rig + "\n");
  const auto run = test::run_rig("chaos " + config + " --duration 15 --seed 1 --json --faults 'host.clock_step:ms=-500@3+5'");
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  EXPECT_EQ(j["faults"].value("host.clock_step", 0), 1) << run.err;
  for (const std::string name : {"front", "left", "right"}) {
    const auto& t = j["topics"]["/sensors/lidar/" + name + "/points"];
    ASSERT_TRUE(t.is_object()) << name << "\n" << run.out;
    EXPECT_GT(t["sent"].get<std::uint64_t>(), 100u) << name;
    EXPECT_EQ(t["unaccounted"].get<std::uint64_t>(), 0u) << name;
  }
  // The GPS-timed Velodyne never left its truth; the two PTP sensors did, flagged.
  EXPECT_EQ(j["topics"]["/sensors/lidar/front/points"]["stamps_flagged"].get<std::uint64_t>(), 0u);
  EXPECT_GT(j["topics"]["/sensors/lidar/left/points"]["stamps_flagged"].get<std::uint64_t>(), 0u);
  EXPECT_GT(j["topics"]["/sensors/lidar/right/points"]["stamps_flagged"].get<std::uint64_t>(), 0u);
  for (const auto& [name, verdict] : j["invariants"].items()) EXPECT_EQ(verdict, "held") << name << "\n" << run.err;
  EXPECT_EQ(run.code, 0) << run.err;
}

// host.network_delay (issue 25): the three mock LIDARs' datagrams held back 50 ms for 4 s. The rig's
// arrival stamps move by the delay; the GPS-timed Velodyne's stamps must not (its truth within
// 0.1 ms); the PTP sensors' stamps stay theirs for 3 s of it, then follow the arrivals, flagged; every
// invariant holds. The host truth records the fault with its parameters. The host is as before (lo's
// qdiscs), also after a campaign SIGKILLed during the fault: nothing of it keeps holding packets.
TEST(ChaosCampaign, AHostNetworkDelayMovesArrivalsNotSensorStamps) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  const auto lidars = [&](const std::string& name) {
    std::string rig = test::read_text(test::source_dir() / "config/mock_rig.yaml");
    rig = rig.substr(0, rig.find("\nfusion:"));  // the three LIDARs: fusion, dbw and cameras apart
    rig.replace(rig.find("profile: cyclonedds/"), std::string("profile: cyclonedds/").size(), "profile: " + src + "/config/cyclonedds/");
    rig.replace(rig.find("domain: 0"), std::string("domain: 0").size(), "domain: " + std::to_string(test::lease_dds_domain()));
    return dir.write(name, rig + "\n");
  };
  const auto qdiscs = [] { return test::run("tc qdisc show dev lo 2>&1").second; };
  const std::string before = qdiscs();

  // Killed (SIGKILL) while the fault holds the packets: its rig up and mocks end (no process of the
  // campaign is left), so nothing holds packets any more, and the host's loopback is untouched.
  {
    const std::string out = (dir.path / "killed").string();
    const std::string cmd = test::rig_bin_or_empty() + " chaos " + lidars("killed.yaml") +
                            " --duration 30 --seed 2 --faults 'host.network_delay:ms=50@0.5+20' --out " + out +
                            " >/dev/null 2>" + (dir.path / "killed.err").string() + " & echo $!";
    const auto [rc, pid_text] = test::run(cmd);
    ASSERT_EQ(rc, 0);
    const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    const auto begun = [&] { return test::read_text(std::filesystem::path(out) / "truth/host.jsonl").find("host.network_delay") != std::string::npos; };
    while (!begun() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ASSERT_TRUE(begun()) << test::read_text(dir.path / "killed.err");
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    // Every process of the campaign names its folder (--out, --truth): none may be left. The last
    // character in brackets, so the pattern does not match the shell that runs pgrep.
    const std::string pattern = out.substr(0, out.size() - 1) + "[" + out.back() + "]";
    const auto alive = [&] { return test::run("pgrep -f -- '" + pattern + "' 2>/dev/null").second; };
    const auto gone_by = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!alive().empty() && std::chrono::steady_clock::now() < gone_by) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(alive(), "") << "processes of the killed campaign still run (they would hold packets)";
    EXPECT_EQ(qdiscs(), before);
  }

  const std::string out = (dir.path / "campaign").string();
  const auto run = test::run_rig("chaos " + lidars("lidars.yaml") +
                                 " --duration 12 --seed 1 --json --faults 'host.network_delay:ms=50@3+4' --out " + out);
  EXPECT_EQ(qdiscs(), before);
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  EXPECT_EQ(j["faults"].value("host.network_delay", 0), 1) << run.err;
  for (const auto& [name, verdict] : j["invariants"].items()) EXPECT_EQ(verdict, "held") << name << "\n" << run.err;
  // The Velodyne's stamps are its GPS time: the delay does not move them.
  EXPECT_LT(j["topics"]["/sensors/lidar/front/points"]["stamp_error_max_ms"].get<double>(), 0.1);
  // The PTP sensors' mappings hold the held network for what it may be, a delay, for 3 s
  // (late_confirm_ns), and only then follow it (flagged): ~10 scans off, not the hold's 40 (before).
  for (const std::string name : {"left", "right"})
    EXPECT_LE(j["topics"]["/sensors/lidar/" + name + "/points"]["stamps_flagged"].get<std::uint64_t>(), 15u) << name;

  // The host's truth: the fault with its parameters, when it began and ended.
  std::int64_t at = 0, until = 0;
  std::ifstream host(out + "/truth/host.jsonl");
  for (std::string line; std::getline(host, line);) {
    const auto f = nlohmann::json::parse(line, nullptr, false);
    if (f.value("kind", "") != "host.network_delay") continue;
    at = f["at"].get<std::int64_t>();
    until = f["until"].get<std::int64_t>();
    EXPECT_NE(f["detail"].get<std::string>().find("ms=50"), std::string::npos) << line;
  }
  ASSERT_GT(at, 0) << "no host.network_delay in the host's truth record";
  EXPECT_NEAR(static_cast<double>(until - at), 4e9, 1e6);
  // The rig's arrival stamps moved by the delay while it lasted, and only then: the Velodyne's first
  // packet arrives just after its scan's first firing, during the fault 50 ms after.
  // Judged by medians and a share: one scan's first packet can wait tens of ms for a loaded host's
  // scheduler (28.8 ms once in a full suite run), which is not the delay.
  std::vector<double> during, outside;
  std::ifstream csv(out + "/monitor.csv");
  std::string line;
  std::getline(csv, line);  // header: topic,seq,acquisition_ns,first_rx_ns,...
  while (std::getline(csv, line)) {
    if (line.rfind("/sensors/lidar/front/points,", 0) != 0) continue;
    std::vector<std::string> c;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) c.push_back(x);
    const std::int64_t acq = std::stoll(c[2]), rx = std::stoll(c[3]);
    const double late_ms = static_cast<double>(rx - acq) * 1e-6;
    if (acq > at + 200'000'000 && acq < until - 200'000'000) {
      during.push_back(late_ms);
      EXPECT_GT(late_ms, 45.0) << "seq " << c[1];  // never earlier than the delay
    } else if (acq < at - 500'000'000 || acq > until + 500'000'000) {
      outside.push_back(late_ms);
    }
  }
  ASSERT_GE(during.size(), 30u);
  ASSERT_GE(outside.size(), 30u);
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  EXPECT_GT(median(during), 45.0);
  EXPECT_LT(median(outside), 10.0);
  const auto late_outside = std::count_if(outside.begin(), outside.end(), [](double ms) { return ms >= 20.0; });
  EXPECT_LE(late_outside * 10, static_cast<std::ptrdiff_t>(outside.size())) << late_outside << " of " << outside.size()
                                                                              << " scans outside the fault came >= 20 ms late";
  EXPECT_EQ(run.code, 0) << run.err;
}

}  // namespace
}  // namespace sensor_rig

namespace sensor_rig {
namespace {

// The in-process Aravis fakes (mock kind aravis-inprocess) write their truth under `rig chaos`, so
// their cameras are judged like the others: every frame the fake made (its truth, by frame id) is
// published or counted, stamped within the bound of its exposure start, and the monitor agrees.
// Before, they wrote none: their topics were absent from the verdict ("not judged").
TEST(ChaosCampaign, InProcessAravisFakesAreJudgedAgainstTheirTruth) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  const std::string domain = std::to_string(test::lease_dds_domain());
  std::string y = "rig:\n  name: inprocess\n  dds: {domain: " + domain + ", profile: " + src +
                  "/config/cyclonedds/loopback.xml}\n  diagnostics_period_ms: 500\ncameras:\n";
  for (const auto& [name, hz] : {std::pair<std::string, int>{"cam_a", 10}, {"cam_b", 20}})
    y += "  - {name: " + name + ", backend: aravis, device: " + name + ", pixel_format: BayerRG8, width: 640, height: 480, " +
         "frame_rate: " + std::to_string(hz) + ", mock: {kind: aravis-inprocess}}\n";
  const std::string config = dir.write("inprocess.yaml", y);
  const auto out = (dir.path / "campaign").string();
  const auto run = test::run_rig("chaos " + config + " --duration 6 --warmup 3 --faults none --json --out " + out);
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  for (const auto& [name, hz] : {std::pair<std::string, double>{"cam_a", 10.0}, {"cam_b", 20.0}}) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(std::filesystem::exists(dir.path / "campaign/truth" / (name + ".jsonl"))) << "no truth record";
    const auto& t = j["topics"]["/sensors/camera/" + name + "/image_raw"];
    ASSERT_TRUE(t.is_object()) << "not judged: " << run.out;
    // The judged window (the campaign's 6 s less its quiet edges, ~3 s): its frames, not a handful.
    EXPECT_GE(t["sent"].get<double>(), 2 * hz);
    EXPECT_EQ(t["unaccounted"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(t["unmatched"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(t["published_twice"].get<std::uint64_t>(), 0u);
    EXPECT_LT(t["stamp_error_p99_ms"].get<double>(), 1.0);
  }
  for (const auto& [inv, verdict] : j["invariants"].items()) EXPECT_EQ(verdict, "held") << inv << "\n" << run.err;
  EXPECT_EQ(run.code, 0) << run.err;
}

// host.network_delay by netem on lo, where the kernel has it: here through a stand-in tc ($RIG_TC,
// tests/rig/fake_tc.hpp; this CI kernel has no sch_netem). A campaign SIGKILLed while its delay
// stands leaves the qdisc and its record; the next campaign removes it before it starts, shapes the
// LIDARs' ports for its own fault (the mocks then hold nothing: the event is the host's, device "lo")
// and removes it when the fault ends; the host truth says so with the parameters.
TEST(ChaosCampaign, ANetemDelayIsRemovedWhenTheFaultEndsAndAfterAKill) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  const auto lidars = [&](const std::string& name) {
    std::string rig = test::read_text(test::source_dir() / "config/mock_rig.yaml");
    rig = rig.substr(0, rig.find("\nfusion:"));
    rig.replace(rig.find("profile: cyclonedds/"), std::string("profile: cyclonedds/").size(), "profile: " + src + "/config/cyclonedds/");
    rig.replace(rig.find("domain: 0"), std::string("domain: 0").size(), "domain: " + std::to_string(test::lease_dds_domain()));
    return dir.write(name, rig + "\n");
  };
  const std::string tc = dir.write("tc", test::kFakeTc);
  std::filesystem::permissions(tc, std::filesystem::perms::owner_all);
  const auto state = dir.path / "lo.state", log = dir.path / "tc.log", run_dir = dir.path / "run";
  const std::string env = "RIG_TC=" + tc + " FAKE_TC_STATE=" + state.string() + " FAKE_TC_LOG=" + log.string() +
                          " RIG_STATE_DIR=" + run_dir.string() + " ";
  {
    const std::string out = (dir.path / "killed").string();
    const auto [rc, pid_text] = test::run(env + test::rig_bin_or_empty() + " chaos " + lidars("killed.yaml") +
                                          " --duration 30 --faults 'host.network_delay:ms=50:jitter_ms=5@0.5+20' --out " + out +
                                          " >/dev/null 2>" + (dir.path / "killed.err").string() + " & echo $!");
    ASSERT_EQ(rc, 0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    // Killed once its delay stands (the state file exists earlier: the start's probe of lo makes and
    // removes a shaping; a kill then left nothing to sweep, and the test failed 1 run in 2).
    const auto delayed = [&] {
      return std::filesystem::exists(state) && test::read_text(state).find("delay 50.000ms") != std::string::npos;
    };
    while (!delayed() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ASSERT_TRUE(delayed()) << test::read_text(dir.path / "killed.err");
    ASSERT_EQ(::kill(static_cast<pid_t>(std::stol(pid_text)), SIGKILL), 0);
    // Its rig up and mocks end (they would send to the next campaign's ports).
    const std::string pattern = out.substr(0, out.size() - 1) + "[" + out.back() + "]";
    const auto gone_by = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!test::run("pgrep -f -- '" + pattern + "' 2>/dev/null").second.empty() && std::chrono::steady_clock::now() < gone_by)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_NE(test::read_text(state).find("delay 50.000ms 5.000ms"), std::string::npos) << test::read_text(state);
  std::filesystem::remove(log);

  const std::string out = (dir.path / "campaign").string();
  struct {
    int code;
    std::string out, err;
  } run;
  std::tie(run.code, run.out) = test::run(env + test::rig_bin_or_empty() + " chaos " + lidars("lidars.yaml") +
                                          " --duration 8 --seed 1 --json --faults 'host.network_delay:ms=40@1+3' --out " + out +
                                          " 2>" + (dir.path / "campaign.err").string());
  run.err = test::read_text(dir.path / "campaign.err");
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  EXPECT_NE(run.err.find("removed the netem delay on lo: a campaign (pid"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("host.network_delay by netem on lo"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(state)) << "lo's qdisc left: " << test::read_text(state);
  EXPECT_FALSE(std::filesystem::exists(run_dir) && !std::filesystem::is_empty(run_dir));
  std::vector<std::string> calls;
  std::istringstream in(test::read_text(log));
  for (std::string l; std::getline(in, l);)
    if (l != "qdisc show dev lo") calls.push_back(l);
  // The sweep of the killed campaign's, then this campaign's own: made, then removed.
  ASSERT_GE(calls.size(), 7u) << test::read_text(log);
  EXPECT_EQ(calls[0], "qdisc del dev lo root handle 1:");
  EXPECT_EQ(calls[calls.size() - 2], "filter del dev lo parent 1: prio 1");
  EXPECT_EQ(calls.back(), "qdisc del dev lo root handle 1:");
  EXPECT_NE(test::read_text(log).find("netem delay 40.000ms\n"), std::string::npos) << test::read_text(log);
  for (const char* port : {" dport 2368 ", " dport 8308 ", " dport 7502 ", " dport 7503 ", " dport 2369 "})
    EXPECT_NE(test::read_text(log).find(port), std::string::npos) << port << "\n" << test::read_text(log);
  const std::string host = test::read_text(std::filesystem::path(out) / "truth/host.jsonl");
  EXPECT_NE(host.find("ms=40, jitter_ms=0, via=netem on lo"), std::string::npos) << host;
  // The event is the host's: no LIDAR mock held a packet for it (their truths record no such fault).
  for (const char* name : {"front", "left", "right"})
    EXPECT_EQ(test::read_text(std::filesystem::path(out) / "truth" / (std::string(name) + ".jsonl")).find("host.network_delay"),
              std::string::npos) << name;
}

}  // namespace
}  // namespace sensor_rig
