// Issue 29, "Message counts match what the monitor received": the mock rig (`rig up`: a synthetic
// VLP-16, a fake-V4L2 camera and a GigE-fake camera), `rig record` and `rig monitor --record` as a
// user runs them, each its own process, over the same window. The file is read by @mcap/core and
// decoded by @foxglove/rosmsg2-serialization (tests/js/mcap_stamps.mjs); the monitor's CSV has a row
// per sample the drivers announced on /rig/stamps (received or lost). Per data topic, over the
// monitor's window (from its first to its last row, by the DDS source timestamp, which the drivers
// give the sample and its stamps alike and the file keeps as publish time), the file must hold
// exactly the samples the monitor received, each by its source timestamp, and every sample the
// recorded /rig/stamps announced. The rig is stopped before the recorder and the monitor, so both
// have seen everything it wrote. A second test stops the recorder (SIGSTOP) for 3.5 s inside the
// window: the same comparison must report the samples it missed (what makes the first able to fail),
// and the recorder must have counted every one (its summary's "missed", cameras as well), also
// those whose announcement it lost too: /rig/stamps' writer keeps its last 64
// of ~60 a second there, so a recorder stopped 3.5 s never hears of some samples at all
// (record_gaps.hpp: seq gaps). Its progress line names them per topic. A third test: a camera's
// JPEGs (image_raw/compressed), announced too (issue 29), one announced and never written and one
// never announced, counted by both the recorder and the monitor.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "../rig/record_support.hpp"
#include "dds_domain_lease.hpp"
#include "wait.hpp"

namespace sensor_rig::rig {
namespace {

std::string profile() { return (test::source_dir() / "config/cyclonedds/loopback.xml").string(); }

// One monitor CSV row: the columns this test needs, by the header's names.
struct MonitorRow {
  std::string topic;
  Nanos publish_ns = 0;
  bool received = false;
};

std::vector<MonitorRow> read_monitor_csv(const std::string& path) {
  std::vector<MonitorRow> rows;
  std::istringstream in(test::read_file(path));
  std::string line;
  if (!std::getline(in, line)) return rows;
  std::map<std::string, std::size_t> col;
  {
    std::istringstream h(line);
    std::size_t i = 0;
    for (std::string name; std::getline(h, name, ',');) col[name] = i++;
  }
  if (!col.count("topic") || !col.count("publish_ns") || !col.count("received_ns")) {
    ADD_FAILURE() << path << ": unexpected header " << line;
    return rows;
  }
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream l(line);
    for (std::string x; std::getline(l, x, ',');) f.push_back(x);
    f.resize(std::max(f.size(), col.size()));
    MonitorRow r;
    r.topic = f[col["topic"]];
    r.publish_ns = f[col["publish_ns"]].empty() ? 0 : std::stoll(f[col["publish_ns"]]);
    r.received = !f[col["received_ns"]].empty() && f[col["received_ns"]] != "0";
    rows.push_back(r);
  }
  return rows;
}

// One topic over the monitor's window [first row, last row] by source timestamp.
struct Compared {
  Nanos from = 0, to = 0;
  std::size_t rows = 0;                   // the monitor's rows: every sample it was told of
  std::set<Nanos> monitor_received;       // rows it received
  std::set<Nanos> in_file;                // the file's messages of the topic in the window
  std::set<Nanos> announced;              // the file's /rig/stamps for the topic in the window
  std::vector<Nanos> not_in_file() const {  // received by the monitor or announced, not recorded
    std::vector<Nanos> r;
    for (const Nanos t : monitor_received)
      if (!in_file.count(t)) r.push_back(t);
    for (const Nanos t : announced)
      if (!in_file.count(t) && !monitor_received.count(t)) r.push_back(t);
    return r;
  }
  std::vector<Nanos> not_received() const {  // recorded, the monitor did not receive
    std::vector<Nanos> r;
    for (const Nanos t : in_file)
      if (!monitor_received.count(t)) r.push_back(t);
    return r;
  }
};

std::map<std::string, Compared> compare(const std::vector<MonitorRow>& rows, const nlohmann::json& dump) {
  std::map<std::string, Compared> by_topic;
  for (const auto& r : rows) {
    Compared& c = by_topic[r.topic];
    c.from = c.rows == 0 ? r.publish_ns : std::min(c.from, r.publish_ns);
    c.to = std::max(c.to, r.publish_ns);
    ++c.rows;
    if (r.received) c.monitor_received.insert(r.publish_ns);
  }
  for (const auto& m : dump["messages"]) {
    const std::string topic = m["topic"];
    if (topic == "/rig/stamps") {
      auto it = by_topic.find(m["stamps_topic"].get<std::string>());
      const Nanos pub = std::stoll(m["publish_ns"].get<std::string>());
      if (it != by_topic.end() && pub >= it->second.from && pub <= it->second.to) it->second.announced.insert(pub);
      continue;
    }
    auto it = by_topic.find(topic);
    if (it == by_topic.end()) continue;
    const Nanos pub = std::stoll(m["publish_time"].get<std::string>());
    if (pub >= it->second.from && pub <= it->second.to) {
      EXPECT_TRUE(it->second.in_file.insert(pub).second) << topic << ": two messages published at " << pub;
    }
  }
  return by_topic;
}

// This process's child whose command line holds `needle` (RigChild does not say its pid); -1 if none.
pid_t child_with(const std::string& needle) {
  for (const auto& e : std::filesystem::directory_iterator("/proc")) {
    const pid_t pid = static_cast<pid_t>(std::atoi(e.path().filename().c_str()));
    if (pid <= 0) continue;
    const std::string stat = test::read_file(e.path() / "stat");
    const auto rp = stat.rfind(')');
    if (rp == std::string::npos) continue;
    char state = 0;
    int ppid = 0;
    if (std::sscanf(stat.c_str() + rp + 1, " %c %d", &state, &ppid) != 2 || ppid != ::getpid()) continue;
    std::string cmd = test::read_file(e.path() / "cmdline");
    for (auto& c : cmd)
      if (c == '\0') c = ' ';
    if (cmd.find(needle) != std::string::npos) return pid;
  }
  return -1;
}

// tests/js/mcap_stamps.mjs over `file`: each message's topic, times and header stamp, /rig/stamps'
// decoded (@mcap/core's indexed reader, @foxglove/rosmsg2-serialization).
nlohmann::json mcap_stamps(const std::string& file) {
  const auto script = test::source_dir() / "tests/js/mcap_stamps.mjs";
  const auto [rc, out] = test::run("node " + script.string() + " " + file + " 2>&1");
  auto j = nlohmann::json::parse(out, nullptr, false);
  if (rc != 0 || j.is_discarded()) return nlohmann::json{{"error", "exit " + std::to_string(rc) + ": " + out.substr(0, 2000)}};
  return j;
}

std::string list(const std::vector<Nanos>& v) {
  std::string s;
  for (const Nanos t : v) s += " " + std::to_string(t);
  return s;
}

class RecordAgainstMonitor : public ::testing::Test {
 protected:
  // Samples a second per device (LIDAR scans, camera frames).
  virtual int rate_hz() const { return 10; }

  void SetUp() override {
    if (!std::filesystem::exists(test::source_dir() / "tests/js/node_modules/@mcap/core"))
      GTEST_FAIL() << "no tests/js/node_modules/@mcap/core (run scripts/setup.sh: npm ci in tests/js)";
    domain_ = test::lease_dds_domain();
    const int p = static_cast<int>(::getpid());
    tag_ = "cnt" + std::to_string(p);
    // A loopback address of this test process's own for the GigE fake (rig up adds it to lo and
    // removes it). Its serial is camera::mock::gige_fake_serial's, which fits every address (7613994;
    // before it, ~1 address in 10 made a fake with no camera and this test ran without it, b334c18).
    const std::string gige_addr = "127.4." + std::to_string(p / 250 % 250) + "." + std::to_string(1 + p % 250);
    config_ = dir_.write(
        "rig.yaml",
        "rig:\n  name: record-counts\n  dds: {domain: " + std::to_string(domain_) + ", profile: " + profile() +
            "}\n  diagnostics_period_ms: 500\nlidars:\n  - name: " + tag_ + "\n    model: VLP-16\n    port: " +
            std::to_string(test::free_udp_port()) +
            "\n    position_port: 0\n    realtime_priority: 0\n    mock: {kind: synthetic, rpm: " + std::to_string(60 * rate_hz()) + "}\ncameras:\n"
            "  - {name: " + tag_ + "_usb, backend: v4l2, device: /dev/video0, pixel_format: YUYV, width: 320, height: 240,"
            " frame_rate: " + std::to_string(rate_hz()) + ", mock: {kind: v4l2-fake}}\n"
            "  - {name: " + tag_ + "_gige, backend: aravis, device: " + gige_addr +
            ", pixel_format: BayerRG8, width: 320, height: 240, frame_rate: " + std::to_string(rate_hz()) +
            ", mock: {kind: gige}}\n");
    topics_ = {"/sensors/lidar/" + tag_ + "/points", "/sensors/camera/" + tag_ + "_usb/image_raw",
               "/sensors/camera/" + tag_ + "_gige/image_raw"};
  }

  std::string path(const std::string& name) const { return (dir_.path / name).string(); }

  // The recorder's newest progress line's topic count (0 before the first).
  static int topics_recorded(const test::RigChild& rec) {
    const std::string err = rec.err();
    const auto at = err.rfind(" topics ");
    if (at == std::string::npos) return 0;
    const auto start = err.find_last_of(' ', at - 1);
    return std::atoi(err.c_str() + start + 1);
  }

  struct Run {
    nlohmann::json dump, rec_summary, monitor_summary;
    std::vector<MonitorRow> rows;
    std::string logs;
  };

  // rig up, then the recorder (every topic), then the monitor (the data topics) once the recorder
  // has subscribed all the rig's topics; `during` runs 0.5 s after the monitor has rows of
  // every topic, and the window goes on `after_ms` after it. The rig stops first; then the monitor and the recorder (SIGINT).
  Run run(const std::function<void(test::RigChild& rec)>& during, int after_ms) {
    Run r;
    test::RigChild up({"up", config_}, path("up.out"), path("up.err"));
    const std::string file = path("rec.mcap");
    // lz4: @mcap/core's reader (JavaScript) takes ~1 s for the ~40 MB instead of ~4 s with zstd's.
    test::RigChild rec({"record", "--out", file, "--domain", std::to_string(domain_), "--dds-profile", profile(),
                        "--compression", "lz4"},
                       path("rec.out"), path("rec.err"));
    const auto tail = [](const std::string& text) { return text.size() > 3000 ? text.substr(text.size() - 3000) : text; };
    const auto logs = [&, tail] {
      return "--- rig up:\n" + tail(test::read_file(path("up.err"))) + "\n--- rig record:\n" + tail(rec.err()) +
             "\n--- rig monitor:\n" + tail(test::read_file(path("mon.err"))) + tail(test::read_file(path("monitor.json")));
    };
    // points, 2 x (image_raw, camera_info), /rig/stamps, /diagnostics
    const Nanos deadline = monotonic_now_ns() + Nanos{test::kDiscoveryMs} * 1'000'000;
    while (topics_recorded(rec) < kTopics && monotonic_now_ns() < deadline && up.poll() < 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (topics_recorded(rec) < kTopics) {
      ADD_FAILURE() << "the recorder did not subscribe the rig's " << kTopics << " topics\n" << logs();
      return r;
    }
    std::vector<std::string> mon_args{"monitor", "--domain", std::to_string(domain_), "--dds-profile", profile(),
                                      "--record", path("monitor.csv"), "--summary", path("monitor.json")};
    mon_args.insert(mon_args.end(), topics_.begin(), topics_.end());
    test::RigChild mon(mon_args, path("mon.out"), path("mon.err"));
    // The monitor counts from 0.5 s after it discovers a topic; its window starts at its first rows.
    const auto rows_for_all = [&] {
      std::map<std::string, int> n;
      for (const auto& row : read_monitor_csv(path("monitor.csv"))) ++n[row.topic];
      for (const auto& t : topics_)
        if (n[t] < 3) return false;
      return true;
    };
    const Nanos rows_deadline = monotonic_now_ns() + Nanos{test::kDiscoveryMs} * 1'000'000;
    while (!rows_for_all() && monotonic_now_ns() < rows_deadline && up.poll() < 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!rows_for_all()) {
      ADD_FAILURE() << "the monitor has no rows for every topic\n" << logs();
      return r;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    during(rec);
    std::this_thread::sleep_for(std::chrono::milliseconds(after_ms));
    EXPECT_EQ(up.signal_and_wait(SIGINT, 15'000), 0) << logs();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_EQ(mon.signal_and_wait(SIGINT, 15'000), 0) << mon.err();
    EXPECT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << logs();
    r.logs = logs();
    r.rec_summary = rec.summary();
    r.monitor_summary = nlohmann::json::parse(test::read_file(path("monitor.json")), nullptr, false);
    r.rows = read_monitor_csv(path("monitor.csv"));
    r.dump = mcap_stamps(file);
    return r;
  }

  static constexpr int kTopics = 7;
  test::TempDir dir_;
  int domain_ = 0;
  std::string tag_, config_;
  std::vector<std::string> topics_;
};

TEST_F(RecordAgainstMonitor, TheFileHoldsExactlyWhatTheMonitorReceived) {
  const Run r = run([](test::RigChild&) {}, 2500);
  if (HasFailure()) return;  // the run said why
  ASSERT_FALSE(r.dump.contains("error")) << r.dump.dump() << r.logs;
  ASSERT_FALSE(r.rec_summary.is_discarded()) << r.logs;
  EXPECT_EQ(r.dump["undecodable"], 0);
  const auto by_topic = compare(r.rows, r.dump);
  for (const auto& t : topics_) {
    SCOPED_TRACE(t);
    ASSERT_EQ(by_topic.count(t), 1u) << "no monitor rows\n" << r.logs;
    const Compared& c = by_topic.at(t);
    // ~3.2 s at 10 Hz; a floor for a loaded host.
    EXPECT_GE(c.monitor_received.size(), 20u);
    EXPECT_EQ(c.in_file.size(), c.monitor_received.size())
        << "recorded " << c.in_file.size() << ", the monitor received " << c.monitor_received.size() << " of "
        << c.rows << " announced";
    EXPECT_TRUE(c.not_in_file().empty()) << "not recorded (source timestamps):" << list(c.not_in_file());
    EXPECT_TRUE(c.not_received().empty()) << "recorded, not received by the monitor:" << list(c.not_received());
    // The monitor was told of every sample (its rows) and the file has their stamps too.
    EXPECT_EQ(c.announced.size(), c.rows);
    EXPECT_EQ(c.monitor_received.size(), c.rows) << "the monitor lost samples";
    // The recorder's own account: everything it took is in the file, nothing dropped.
    const auto& s = r.rec_summary["topics"][t];
    EXPECT_EQ(s["received"], s["written"]) << s.dump();
    EXPECT_EQ(r.dump["channels"][t]["count"], s["written"]) << s.dump();
  }
  for (const auto& [cause, n] : r.rec_summary["drops"].items()) EXPECT_EQ(n, 0) << cause << " " << r.rec_summary.dump();
  EXPECT_EQ(r.rec_summary.value("unannounced", -1), 0) << r.rec_summary.dump();
  EXPECT_EQ(r.rec_summary.value("missed_overflow", -1), 0) << r.rec_summary.dump();
  ASSERT_TRUE(r.monitor_summary.is_array()) << test::read_file(path("monitor.json"));
  for (const auto& s : r.monitor_summary) {
    if (!s.contains("topic")) continue;
    EXPECT_EQ(s["lost"], 0) << s.dump();
    // It received (whole run, from its match) at least what its rows say.
    const auto c = by_topic.find(s["topic"].get<std::string>());
    ASSERT_NE(c, by_topic.end()) << s.dump();
    EXPECT_GE(s["received"].get<std::size_t>(), c->second.monitor_received.size()) << s.dump();
  }
}

// The comparison above against a recorder that misses samples: stopped (SIGSTOP) for 3.5 s, its
// DDS threads too, while the drivers' writers keep 2 samples each for it and /rig/stamps' writer its
// last 64 announcements of every topic (0.8 s of this rig at 20 Hz a device; at 10 Hz the socket's
// 4 MB held the rest of a 3.5 s stop, no announcement was lost). What it missed must be named, by
// source timestamp, against the monitor (never stopped: it heard every announcement) and the
// recording; the recorder must count exactly that, announcement lost or not.
class RecordFarBehind : public RecordAgainstMonitor {
 protected:
  int rate_hz() const override { return 20; }
};

TEST_F(RecordFarBehind, ARecorderThatMissesSamplesCountsEachOne) {
  const Run r = run([&](test::RigChild&) {
    const pid_t rec = child_with(" record --out " + path("rec.mcap"));
    ASSERT_GT(rec, 0);
    ASSERT_EQ(::kill(rec, SIGSTOP), 0);
    std::this_thread::sleep_for(std::chrono::milliseconds(3500));
    ASSERT_EQ(::kill(rec, SIGCONT), 0);
  }, 1000);
  if (HasFailure()) return;
  ASSERT_FALSE(r.dump.contains("error")) << r.dump.dump() << r.logs;
  ASSERT_FALSE(r.rec_summary.is_discarded()) << r.logs;
  const auto by_topic = compare(r.rows, r.dump);
  // The recorder's last progress line (after its summary's counts were final).
  const std::string err = test::read_file(path("rec.err"));
  const auto last_line_at = err.rfind("rig record: ", err.size() > 1 ? err.size() - 2 : 0);
  const std::string progress = last_line_at == std::string::npos ? "" : err.substr(last_line_at);
  std::size_t lost_announcements = 0;
  for (const auto& t : topics_) {
    SCOPED_TRACE(t);
    ASSERT_EQ(by_topic.count(t), 1u) << "no monitor rows\n" << r.logs;
    const Compared& c = by_topic.at(t);
    EXPECT_GE(c.monitor_received.size(), 30u);
    // The monitor heard of every sample and received it: the truth of what was published.
    EXPECT_EQ(c.monitor_received.size(), c.rows) << "the monitor lost samples";
    // 3.5 s at 20 Hz is 70 samples; only the writer's last 2 and what the socket held come late.
    const std::size_t truth = c.not_in_file().size();
    EXPECT_GE(truth, 20u) << "recorded " << c.in_file.size() << " of " << c.monitor_received.size();
    // What the recorder could count before seq gaps: the announcements it received without their sample.
    std::size_t announced_missing = 0;
    for (const Nanos a : c.announced) announced_missing += c.in_file.count(a) == 0 ? 1 : 0;
    lost_announcements += c.rows - c.announced.size();
    const auto& s = r.rec_summary["topics"][t];
    const auto missed = s.value("missed", std::size_t{0});
    const auto unannounced = s.value("unannounced", std::size_t{0});
    // Exact on every topic, cameras too: the gaps are read from the announcements' own numbers
    // (SourceStamps.published), not from a camera's frame ids (before: "missed" + "unannounced" on
    // cameras, an upper bound).
    EXPECT_EQ(missed, truth) << s.dump();
    EXPECT_EQ(unannounced, 0u) << s.dump();
    EXPECT_EQ(s.value("missed_overflow", 0), 0) << s.dump();
    EXPECT_EQ(s["received"], s["written"]) << s.dump();
    // The progress line names the topic's count (record_cli's "missed: /topic N, ...").
    if (missed > 0) {
      EXPECT_NE(progress.find(" " + t + " " + std::to_string(missed)), std::string::npos) << progress;
    }
    std::cout << t << ": " << c.rows << " published, " << c.in_file.size() << " recorded, " << truth
              << " missing (" << c.rows - c.announced.size() << " announcements missing from the file, "
              << announced_missing << " announced and missing); the recorder reports missed " << missed
              << ", unannounced " << unannounced << "\n";
  }
  // The stop outlasted /rig/stamps' history: the recording lacks announcements too (else this test
  // would not tell the seq gaps' count from the announced one's).
  EXPECT_GT(lost_announcements, 0u);
  EXPECT_NE(progress.find("  missed: "), std::string::npos) << progress;
  ASSERT_TRUE(r.monitor_summary.is_array()) << test::read_file(path("monitor.json"));
  for (const auto& m : r.monitor_summary) {
    if (m.contains("topic")) {
      EXPECT_EQ(m["lost"], 0) << m.dump();
    }
  }
  EXPECT_EQ(r.rec_summary["drops"]["queue_full"], 0);
  EXPECT_EQ(r.rec_summary["drops"]["disk"], 0);
  std::cout << "last progress line: " << progress;
}

// Issue 29: a camera's JPEGs (image_raw/compressed) are announced on /rig/stamps as its image_raw
// is, with the frame's seq. Against a publisher here that does what the camera does, but for two
// frames: one announced and never written, one neither (a gap in seq, as a frame the worker never
// compressed). `rig record` counts the first missed and not the second: the announcements are
// numbered (SourceStamps.published), and a frame never published is no sample the recorder missed
// (before, seq gaps on a camera counted it `unannounced`); `rig monitor` reads the JPEGs, joins them
// with their stamps and counts both lost (the expired announcement and the seq gap). A monitor that did not read CompressedImage
// never matches the writer (first assertion) and could count nothing.
TEST(RecordAndMonitorCompressed, AJpegAnnouncedAndNeverReceivedIsCountedByBoth) {
  test::TempDir dir;
  const int domain = test::lease_dds_domain();
  const std::string topic = "/sensors/camera/cmp" + std::to_string(::getpid()) + "/image_raw/compressed";
  const auto path = [&](const std::string& name) { return (dir.path / name).string(); };
  test::RigChild rec({"record", "--out", path("rec.mcap"), "--domain", std::to_string(domain), "--dds-profile", profile(),
                      topic, dds::kStampsTopic},
                     path("rec.out"), path("rec.err"));
  test::RigChild mon({"monitor", "--domain", std::to_string(domain), "--dds-profile", profile(), "--loss-timeout", "0.5",
                      "--record", path("monitor.csv"), "--summary", path("monitor.json"), topic},
                     path("mon.out"), path("mon.err"));
  dds::Participant p(dds::DomainConfig{static_cast<dds_domainid_t>(domain), profile()});
  dds::QosSpec q;  // reliable, keep-last: as a camera's
  q.depth = 16;
  dds::Topic<msg::CompressedImage> t(p, topic, q);
  dds::Writer<msg::CompressedImage> writer(p, t, q);
  dds::StampsWriter stamps(p);
  const auto logs = [&] { return "--- rig record:\n" + rec.err() + "\n--- rig monitor:\n" + test::read_file(path("mon.err")); };
  ASSERT_TRUE(writer.wait_for_readers(2, test::kDiscoveryMs)) << "the recorder and the monitor read the JPEGs\n" << logs();
  ASSERT_TRUE(stamps.wait_for_readers(2, test::kDiscoveryMs)) << logs();

  const Nanos base = vehicle_now_ns();
  std::vector<std::uint8_t> jpeg(700, 0xAB);
  char frame[] = "cmp_frame", format[] = "bayer_rggb8; jpeg compressed bgr8";
  Nanos last_publish = 0;
  // Frame `seq`, stamped 20 ms apart: written (unless not), then announced (as image_outputs.cpp).
  const auto frame_out = [&](std::uint64_t seq, bool write) {
    msg::CompressedImage ci{};
    ci.header.stamp = msg::to_time(base + static_cast<Nanos>(seq) * 20'000'000);
    ci.header.frame_id = frame;
    ci.format = format;
    ci.data = {static_cast<std::uint32_t>(jpeg.size()), static_cast<std::uint32_t>(jpeg.size()), jpeg.data(), false};
    const Nanos publish = vehicle_now_ns();
    if (write) {
      EXPECT_TRUE(writer.write(ci, publish).ok());
    }
    dds::SampleStamps s{msg::from_time(ci.header.stamp), publish, publish, publish, publish, vehicle_now_ns(), 1, 0, ci.data._length};
    stamps.write(topic, ci.header.stamp, frame, seq, s);
    last_publish = publish;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // a 50 Hz camera
  };
  // Both count from 500 ms after they discovered the topic (kMatchDelayNs in monitor.cpp and
  // recorder.cpp), before their readers matched: frames for 700 ms first, all delivered.
  std::uint64_t seq = 1;
  const Nanos counting = monotonic_now_ns() + 700'000'000;
  while (monotonic_now_ns() < counting) frame_out(seq++, true);
  const std::uint64_t never_written = seq + 2, never_compressed = seq + 5, last = seq + 8;
  for (; seq <= last; ++seq)
    if (seq != never_compressed) frame_out(seq, seq != never_written);
  // The monitor decides in seq order: the last frame's row comes once the unwritten one expired.
  const auto decided = [&] {
    for (const auto& row : read_monitor_csv(path("monitor.csv")))
      if (row.topic == topic && row.publish_ns == last_publish) return true;
    return false;
  };
  ASSERT_TRUE(test::wait_for(decided, 5000)) << logs();
  EXPECT_EQ(mon.signal_and_wait(SIGINT, 15'000), 0) << logs();
  EXPECT_EQ(rec.signal_and_wait(SIGINT, 15'000), 0) << logs();

  auto summary = rec.summary();
  ASSERT_FALSE(summary.is_discarded()) << rec.out() << logs();
  const auto& r = summary["topics"][topic];
  EXPECT_EQ(r["type"], "sensor_msgs/msg/CompressedImage") << r.dump();
  EXPECT_EQ(r["missed"], 1) << r.dump();
  EXPECT_EQ(r["unannounced"], 0) << r.dump();
  EXPECT_EQ(r["received"], seq - 3) << r.dump();  // every frame written: 1 .. last but two
  const auto monitor = nlohmann::json::parse(test::read_file(path("monitor.json")), nullptr, false);
  ASSERT_TRUE(monitor.is_array()) << test::read_file(path("monitor.json"));
  bool seen = false;
  for (const auto& m : monitor) {
    if (m.value("topic", "") != topic) continue;
    seen = true;
    EXPECT_EQ(m["lost"], 2) << m.dump();
    EXPECT_GE(m["received"].get<std::uint64_t>(), 6u) << m.dump();  // at least the frames after the gaps' start
  }
  EXPECT_TRUE(seen) << monitor.dump();
  // The rows: every announced frame once, the unwritten one not received.
  std::size_t rows = 0, not_received = 0;
  for (const auto& row : read_monitor_csv(path("monitor.csv")))
    if (row.topic == topic) {
      ++rows;
      not_received += row.received ? 0 : 1;
    }
  EXPECT_EQ(not_received, 1u);
  EXPECT_GE(rows, 8u);
}

}  // namespace
}  // namespace sensor_rig::rig
