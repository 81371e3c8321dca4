// `rig view` as a user runs it: the real `rig` binary in its own process, DDS writers here (clouds
// and images, their bytes and stamps remembered), and the Foxglove client written by others
// (tests/js/view_client.mjs: @foxglove/ws-protocol, messages decoded by
// @foxglove/rosmsg2-serialization with the schemas `rig view` advertised) in further processes.
// Checked against what was written: the channels advertised, every decoded cloud and image (stamp,
// size, fields, FNV-1a of the data), unadvertise when a writer goes, a raw reader only while a client
// subscribes, a stalled client beside a full-rate one (its drops counted in rig view's stats), bad
// client input answered and survived, SIGTERM.
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <atomic>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/dds/roudi.hpp"
#include "rig_process.hpp"
#include "sensor_rig/dds/types.hpp"
#include "view_client.hpp"
#include "wait.hpp"

namespace sensor_rig {
namespace {

using nlohmann::json;
constexpr dds_domainid_t kDomain = 33;
const std::string kCloud = "/test/view/points";
const std::string kImage = "/test/view/image_raw";

struct Sent {
  std::size_t len = 0;
  std::uint32_t fnv = 0;
};

// A PointCloud2 writer and an Image writer at `hz`, each sample's data different; what was written
// is remembered by stamp.
class Publishers {
  static dds::DomainConfig domain(dds::Transport transport) {
    dds::DomainConfig d;
    d.domain_id = kDomain;
    d.transport = transport;
    return d;
  }

 public:
  Publishers(std::uint32_t points, std::uint32_t image_w, std::uint32_t image_h, int hz,
             dds::Transport transport = dds::Transport::kUdp)
      : participant_(domain(transport)), cloud_topic_(participant_, kCloud), image_topic_(participant_, kImage),
        cloud_(std::make_unique<dds::Writer<msg::PointCloud2>>(participant_, cloud_topic_)),
        image_(std::make_unique<dds::Writer<msg::Image>>(participant_, image_topic_)) {
    thread_ = std::thread([=, this] { run(points, image_w, image_h, hz); });
  }
  ~Publishers() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  void drop_image_writer() {
    std::lock_guard lock(mu_);
    image_.reset();
  }
  std::map<Nanos, Sent> clouds() const {
    std::lock_guard lock(mu_);
    return clouds_;
  }
  std::map<Nanos, Sent> images() const {
    std::lock_guard lock(mu_);
    return images_;
  }

 private:
  void run(std::uint32_t points, std::uint32_t w, std::uint32_t h, int hz) {
    struct Field {
      const char* name;
      std::uint32_t offset;
      std::uint8_t datatype;
    };
    static constexpr Field kFields[] = {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}};
    auto fields = msg::point_fields(kFields);
    std::vector<std::uint8_t> cloud_data(std::size_t{points} * 16);
    std::vector<std::uint8_t> image_data(std::size_t{w} * h * 3);
    std::uint32_t n = 0;
    auto next = std::chrono::steady_clock::now();
    while (!stop_) {
      next += std::chrono::microseconds(1'000'000 / hz);
      std::this_thread::sleep_until(next);
      ++n;
      for (std::size_t i = 0; i < cloud_data.size(); ++i) cloud_data[i] = static_cast<std::uint8_t>(i * 13 + n);
      for (std::size_t i = 0; i < image_data.size(); ++i) image_data[i] = static_cast<std::uint8_t>((i >> 3) + n * 5);
      msg::PointCloud2 pc{};
      const Nanos stamp = vehicle_now_ns();
      pc.header.stamp = msg::to_time(stamp);
      pc.header.frame_id = const_cast<char*>("lidar_test");
      pc.height = 1;
      pc.width = points;
      pc.fields._buffer = fields.data();
      pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(fields.size());
      pc.point_step = 16;
      pc.row_step = 16 * points;
      pc.data._buffer = cloud_data.data();
      pc.data._length = pc.data._maximum = static_cast<std::uint32_t>(cloud_data.size());
      pc.is_dense = true;
      msg::Image im{};
      im.header.stamp = msg::to_time(stamp + 1);
      im.header.frame_id = const_cast<char*>("camera_test");
      im.height = h;
      im.width = w;
      im.encoding = const_cast<char*>("rgb8");
      im.step = 3 * w;
      im.data._buffer = image_data.data();
      im.data._length = im.data._maximum = static_cast<std::uint32_t>(image_data.size());
      std::lock_guard lock(mu_);
      if (cloud_->write(pc, vehicle_now_ns()).ok())
        clouds_[stamp] = Sent{cloud_data.size(), test::fnv1a(cloud_data.data(), cloud_data.size())};
      if (image_ && image_->write(im, vehicle_now_ns()).ok())
        images_[stamp + 1] = Sent{image_data.size(), test::fnv1a(image_data.data(), image_data.size())};
    }
  }

  dds::Participant participant_;
  dds::Topic<msg::PointCloud2> cloud_topic_;
  dds::Topic<msg::Image> image_topic_;
  std::unique_ptr<dds::Writer<msg::PointCloud2>> cloud_;
  std::unique_ptr<dds::Writer<msg::Image>> image_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;
  std::map<Nanos, Sent> clouds_, images_;
  std::thread thread_;
};

// `rig view` in its own process, its JSON stats lines collected.
class RigView {
 public:
  explicit RigView(const std::string& transport = "udp") : port_(test::free_tcp_port()) {
    ChildOptions o;
    o.pipe_stdio = true;
    proc_ = ChildProcess({std::getenv("RIG_BIN") != nullptr ? std::getenv("RIG_BIN") : RIG_DEFAULT_BIN, "view",
                          "--domain", std::to_string(kDomain), "--port", std::to_string(port_), "--stats-interval",
                          "0.5", "--transport", transport},
                         o);
  }
  [[nodiscard]] std::string url() const { return "ws://127.0.0.1:" + std::to_string(port_); }
  // The newest stats line (after reading what is there).
  json stats() {
    for (auto& l : proc_.read_lines()) {
      auto j = json::parse(l, nullptr, false);
      if (!j.is_discarded()) last_ = std::move(j);
    }
    return last_;
  }
  ChildProcess& process() { return proc_; }

 private:
  int port_;
  ChildProcess proc_;
  json last_ = json::object();
};

// Share of one core `pid` used over `ms` (user + system, /proc/PID/stat).
double cpu_share(pid_t pid, int ms) {
  auto ticks = [pid] {
    std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    std::getline(f, line);
    std::istringstream in(line.substr(line.rfind(')') + 2));
    std::string field;
    long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && in >> field; ++i) {
      if (i == 14) utime = std::stoll(field);
      if (i == 15) stime = std::stoll(field);
    }
    return utime + stime;
  };
  const long long t0 = ticks();
  std::this_thread::sleep_for(std::chrono::milliseconds(ms));
  return static_cast<double>(ticks() - t0) / static_cast<double>(::sysconf(_SC_CLK_TCK)) / (ms / 1000.0);
}

std::size_t check_against(const test::ViewClient& c, const std::string& topic, const std::map<Nanos, Sent>& sent,
                          bool cloud) {
  std::size_t n = 0;
  Nanos last = 0;
  for (const auto& m : c.events("message")) {
    if (m["topic"] != topic) continue;
    const Nanos stamp = std::stoll(m["stamp_ns"].get<std::string>());
    const auto it = sent.find(stamp);
    EXPECT_NE(it, sent.end()) << topic << ": never written: " << stamp;
    if (it == sent.end()) continue;
    const auto& s = m["summary"];
    EXPECT_EQ(s["data"]["len"].get<std::size_t>(), it->second.len) << topic;
    EXPECT_EQ(s["data"]["fnv1a"].get<std::uint32_t>(), it->second.fnv) << topic << " at " << stamp;
    if (cloud) {
      EXPECT_EQ(s["header"]["frame_id"], "lidar_test");
      EXPECT_EQ(s["point_step"], 16);
      EXPECT_EQ(s["width"].get<std::size_t>() * 16, it->second.len);
      EXPECT_EQ(s["fields"].size(), 4u);
      if (s["fields"].size() == 4) {
        EXPECT_EQ(s["fields"][3]["name"], "intensity");
        EXPECT_EQ(s["fields"][3]["offset"], 12);
      }
    } else {
      EXPECT_EQ(s["header"]["frame_id"], "camera_test");
      EXPECT_EQ(s["encoding"], "rgb8");
      EXPECT_EQ(s["step"].get<std::size_t>() * s["height"].get<std::size_t>(), it->second.len);
    }
    // Stamped by rig view when it took the sample: after it was written.
    EXPECT_GE(std::stoll(m["receive_ns"].get<std::string>()), stamp);
    EXPECT_GT(stamp, last) << topic << ": out of order";
    last = stamp;
    ++n;
  }
  return n;
}

class RigViewTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string missing = test::view_client_missing();
    if (!missing.empty()) GTEST_FAIL() << missing;
  }
};

TEST_F(RigViewTest, AdvertisesTheTopicsAndStreamsCloudsAndImagesAsWritten) {
  Publishers pub(20'000, 320, 240, 10);
  RigView view;
  ASSERT_TRUE(test::wait_for([&] { return view.stats().value("channels", 0) >= 2; }, 30'000))
      << "rig view did not advertise both topics: " << view.stats().dump();
  EXPECT_EQ(view.stats()["dds"]["readers_opened"], 0) << "a reader before any client subscribed";

  test::ViewClient c({"--url", view.url(), "--wait-topics", kCloud + "," + kImage, "--subscribe",
                      kCloud + "," + kImage, "--count", "15", "--print-messages", "--timeout", "60"});
  ASSERT_TRUE(c.wait_exit(90'000)) << c.transcript();
  EXPECT_EQ(c.exit_status(), 0) << c.transcript();
  std::map<std::string, json> channels;
  for (const auto& adv : c.events("advertise"))
    for (const auto& ch : adv["channels"]) channels[ch["topic"].get<std::string>()] = ch;
  ASSERT_EQ(channels.count(kCloud), 1u) << c.transcript();
  ASSERT_EQ(channels.count(kImage), 1u);
  EXPECT_EQ(channels[kCloud]["schemaName"], "sensor_msgs/msg/PointCloud2");
  EXPECT_EQ(channels[kImage]["schemaName"], "sensor_msgs/msg/Image");
  for (const auto* t : {&kCloud, &kImage}) {
    EXPECT_EQ(channels[*t]["encoding"], "cdr");
    EXPECT_EQ(channels[*t]["schemaEncoding"], "ros2msg");
  }
  EXPECT_GE(check_against(c, kCloud, pub.clouds(), true), 15u) << c.transcript();
  EXPECT_GE(check_against(c, kImage, pub.images(), false), 15u);
  EXPECT_TRUE(c.events("decode_error").empty() && c.events("schema_error").empty()) << c.transcript();

  // Its readers went with the client; both were opened for it.
  ASSERT_TRUE(test::wait_for(
      [&] {
        const json s = view.stats();
        return s.value("clients_closed", 0) == 1 && s["dds"]["readers"].empty();
      },
      10'000))
      << view.stats().dump();
  EXPECT_EQ(view.stats()["dds"]["readers_opened"], 2);
  // Idle again (no client, no reader): it sleeps in its waitset (a guard left triggered once made
  // it spin at a whole core).
  EXPECT_LT(cpu_share(view.process().pid(), 2000), 0.1);

  // A client that stays: the image writer goes, the client is told (unadvertise).
  test::ViewClient stay({"--url", view.url(), "--wait-topics", kCloud + "," + kImage, "--subscribe-all", "--duration",
                         "30", "--timeout", "60"});
  ASSERT_TRUE(test::wait_for(
      [&] {
        stay.collect(10);
        return !stay.events("advertise").empty() && view.stats()["dds"]["readers"].size() == 2;
      },
      30'000))
      << stay.transcript();
  pub.drop_image_writer();
  ASSERT_TRUE(test::wait_for(
      [&] {
        stay.collect(10);
        return !stay.events("unadvertise").empty();
      },
      30'000))
      << stay.transcript();
  EXPECT_EQ(stay.events("unadvertise")[0]["topics"], json::array({kImage}));
  ASSERT_TRUE(test::wait_for([&] { return view.stats()["dds"]["readers"].size() == 1; }, 10'000));

  // SIGTERM: the client is told (going away), rig view exits 0 with a final stats line.
  view.process().signal(SIGTERM);
  ASSERT_TRUE(view.process().wait_exit(10'000));
  EXPECT_EQ(view.process().exit_status(), 0);
  ASSERT_TRUE(stay.wait_exit(10'000)) << stay.transcript();
  ASSERT_FALSE(stay.events("close").empty());
  EXPECT_EQ(stay.events("close")[0]["code"], 1001);
  EXPECT_EQ(view.stats().value("final", false), true);
}

// A client that stops reading loses its oldest clouds (counted by rig view) while another receives
// every cloud written; bad input from a third is answered and changes nothing.
TEST_F(RigViewTest, AStalledClientDoesNotSlowAnotherAndBadInputIsAnswered) {
  Publishers pub(65'536, 16, 16, 10);  // 1 MiB clouds at 10 Hz
  RigView view;
  ASSERT_TRUE(test::wait_for([&] { return view.stats().value("channels", 0) >= 2; }, 30'000)) << view.stats().dump();
  test::ViewClient stalled({"--url", view.url(), "--wait-topics", kCloud, "--subscribe", kCloud, "--stall-after", "2",
                            "--duration", "60", "--timeout", "90"});
  ASSERT_TRUE(test::wait_for(
      [&] {
        const json s = view.stats();
        return !s["clients"].empty() && s["clients"][0].value("dropped", 0) > 0;
      },
      40'000))
      << view.stats().dump() << stalled.transcript();
  test::ViewClient bad({"--url", view.url(), "--bad-input", "--duration", "1", "--timeout", "30"});
  test::ViewClient fast({"--url", view.url(), "--wait-topics", kCloud, "--subscribe", kCloud, "--duration", "5",
                         "--print-messages", "--timeout", "60"});
  ASSERT_TRUE(fast.wait_exit(60'000)) << fast.transcript();
  ASSERT_TRUE(bad.wait_exit(30'000)) << bad.transcript();
  json s;  // a stats line written after both left (only the stalled client connected)
  ASSERT_TRUE(test::wait_for(
      [&] {
        s = view.stats();
        return s.value("clients_closed", 0) == 2 && s["clients"].size() == 1;
      },
      10'000))
      << s.dump();
  const auto clouds = pub.clouds();
  pub.stop();
  stalled.stop();

  EXPECT_EQ(fast.exit_status(), 0) << fast.transcript();
  const std::size_t got = check_against(fast, kCloud, clouds, true);
  const auto msgs = fast.events("message");
  ASSERT_GE(msgs.size(), 2u) << fast.transcript();
  const Nanos first = std::stoll(msgs.front()["stamp_ns"].get<std::string>());
  const Nanos last = std::stoll(msgs.back()["stamp_ns"].get<std::string>());
  const auto written = static_cast<std::size_t>(std::count_if(
      clouds.begin(), clouds.end(), [&](const auto& kv) { return kv.first >= first && kv.first <= last; }));
  // Every cloud written in its window, at the full 10 Hz for ~5 s: the stalled client costs it nothing.
  EXPECT_EQ(got, written);
  EXPECT_GE(got, 40u);
  ASSERT_FALSE(s["clients"].empty()) << s.dump();
  EXPECT_GT(s["clients"][0]["dropped"].get<std::uint64_t>(), 10u) << s.dump();
  EXPECT_LE(s["clients"][0]["messages_sent"].get<std::uint64_t>(), 30u) << s.dump();
  EXPECT_EQ(s["protocol_errors"], 9) << s.dump();
  std::size_t errors = 0;
  const json summary = bad.summary();
  for (const auto& st : summary["statuses"]) errors += st["level"] == 2 ? 1 : 0;
  EXPECT_EQ(errors, 9u) << bad.transcript();
}

// iox-roudi, stopping, sends SIGTERM to every process registered with it, this test's own included
// (its publishers' participant): ignored from before the RouDi starts until after it has stopped.
class IgnoreSigterm {
 public:
  IgnoreSigterm() {
    struct sigaction ign {};
    ign.sa_handler = SIG_IGN;
    ::sigaction(SIGTERM, &ign, &old_);
  }
  ~IgnoreSigterm() { ::sigaction(SIGTERM, &old_, nullptr); }
  IgnoreSigterm(const IgnoreSigterm&) = delete;
  IgnoreSigterm& operator=(const IgnoreSigterm&) = delete;

 private:
  struct sigaction old_ {};
};

// With shared memory on both sides (their own RouDi), a sample reaches rig view as an iceoryx chunk
// (dds::RawSample: a header made by the reader, then the chunk: two pieces); the client must still
// get each cloud and image whole.
TEST_F(RigViewTest, OverSharedMemoryCloudsAndImagesArriveWhole) {
  if (::access("/usr/bin/iox-roudi", X_OK) != 0) GTEST_SKIP() << "no iox-roudi (Debian package iceoryx)";
  if (dds::probe_roudi().pid != 0) GTEST_SKIP() << "another RouDi runs on this machine; this test needs its own";
  const std::string log = "/tmp/rig-view-test-roudi-" + std::to_string(::getpid()) + ".log";
  struct RemoveLog {
    std::string path;
    ~RemoveLog() { std::remove(path.c_str()); }
  } remove_log{log};
  IgnoreSigterm ignore_sigterm;  // destroyed after the RouDi
  dds::RouDi roudi("", log, false);
  Publishers pub(20'000, 320, 240, 10, dds::Transport::kShm);
  RigView view("shm");
  ASSERT_TRUE(test::wait_for([&] { return view.stats().value("channels", 0) >= 2; }, 30'000)) << view.stats().dump();
  test::ViewClient c({"--url", view.url(), "--wait-topics", kCloud + "," + kImage, "--subscribe", kCloud + "," + kImage,
                      "--count", "10", "--print-messages", "--timeout", "60"});
  ASSERT_TRUE(c.wait_exit(90'000)) << c.transcript();
  EXPECT_EQ(c.exit_status(), 0) << c.transcript();
  EXPECT_GE(check_against(c, kCloud, pub.clouds(), true), 10u) << c.transcript();
  EXPECT_GE(check_against(c, kImage, pub.images(), false), 10u);
  view.process().signal(SIGTERM);
  ASSERT_TRUE(view.process().wait_exit(10'000));
  EXPECT_EQ(view.process().exit_status(), 0);
}

}  // namespace
}  // namespace sensor_rig
