// The view server (no DDS) against the Foxglove client written by others (tests/js/view_client.mjs:
// @foxglove/ws-protocol over `ws`, messages decoded by @foxglove/rosmsg2-serialization with the
// schema the server advertised), each client its own process on loopback. The payloads are CDR this
// test encodes, and every decoded message is checked against what was published (stamp, length,
// FNV-1a of the bytes); counts against what the server says it sent and dropped.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/view/server.hpp"
#include "view_client.hpp"
#include "wait.hpp"

namespace sensor_rig::view {
namespace {

using nlohmann::json;

// A header and a byte sequence: decodes like a PointCloud2's or an Image's header and data.
constexpr const char* kBlobSchema =
    "std_msgs/Header header\nuint8[] data\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    "================================================================================\n"
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";

ChannelSpec blob_channel(const std::string& topic) {
  return ChannelSpec{topic, "cdr", "sensor_rig_test/msg/Blob", kBlobSchema, "ros2msg"};
}

// XCDR1 little endian, as a ROS 2 node writes it.
std::vector<std::uint8_t> blob_cdr(Nanos stamp, const std::vector<std::uint8_t>& data) {
  std::vector<std::uint8_t> b{0x00, 0x01, 0x00, 0x00};
  auto u32 = [&](std::uint32_t v) {
    while (b.size() % 4 != 0) b.push_back(0);
    for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  u32(static_cast<std::uint32_t>(stamp / 1'000'000'000));
  u32(static_cast<std::uint32_t>(stamp % 1'000'000'000));
  const std::string frame = "test";
  u32(static_cast<std::uint32_t>(frame.size() + 1));
  b.insert(b.end(), frame.begin(), frame.end());
  b.push_back(0);
  u32(static_cast<std::uint32_t>(data.size()));
  b.insert(b.end(), data.begin(), data.end());
  return b;
}

struct Truth {
  std::size_t len = 0;
  std::uint32_t fnv = 0;
};

// Publishes blobs on one channel at a rate while it has subscribers; remembers what it sent.
class Publisher {
 public:
  Publisher(Server& server, ChannelId ch, std::size_t bytes, int hz) : server_(server), ch_(ch) {
    thread_ = std::thread([this, bytes, hz] { run(bytes, hz); });
  }
  ~Publisher() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::map<Nanos, Truth> sent() const {
    std::lock_guard lock(mu_);
    return sent_;
  }
  Nanos max_publish_ns() const { return max_publish_ns_; }

 private:
  void run(std::size_t bytes, int hz) {
    std::uint32_t n = 0;
    auto next = std::chrono::steady_clock::now();
    while (!stop_) {
      next += std::chrono::microseconds(1'000'000 / hz);
      std::this_thread::sleep_until(next);
      if (!server_.has_subscribers(ch_)) continue;
      std::vector<std::uint8_t> data(bytes);
      for (std::size_t i = 0; i < bytes; ++i) data[i] = static_cast<std::uint8_t>((i * 31 + n * 7) ^ (i >> 8));
      ++n;
      const Nanos stamp = vehicle_now_ns();
      const auto cdr = blob_cdr(stamp, data);
      const Nanos t0 = monotonic_now_ns();
      server_.publish(ch_, static_cast<std::uint64_t>(stamp), cdr.data(), cdr.size());
      max_publish_ns_ = std::max<Nanos>(max_publish_ns_, monotonic_now_ns() - t0);
      std::lock_guard lock(mu_);
      sent_[stamp] = Truth{data.size(), test::fnv1a(data.data(), data.size())};
    }
  }
  Server& server_;
  ChannelId ch_;
  std::atomic<bool> stop_{false};
  std::atomic<Nanos> max_publish_ns_{0};
  mutable std::mutex mu_;
  std::map<Nanos, Truth> sent_;
  std::thread thread_;
};

class ViewServer : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string missing = test::view_client_missing();
    if (!missing.empty()) GTEST_FAIL() << missing;
    ServerOptions o;
    o.port = 0;
    server_ = std::make_unique<Server>(o);
    server_->start(Server::Callbacks{[this](ChannelId c) {
                                       std::lock_guard lock(mu_);
                                       firsts_.push_back(c);
                                     },
                                     [this](ChannelId c) {
                                       std::lock_guard lock(mu_);
                                       lasts_.push_back(c);
                                     }});
    url_ = "ws://127.0.0.1:" + std::to_string(server_->port());
  }
  std::vector<ChannelId> firsts() {
    std::lock_guard lock(mu_);
    return firsts_;
  }
  std::vector<ChannelId> lasts() {
    std::lock_guard lock(mu_);
    return lasts_;
  }
  // Every decoded message of `client` on `topic` is one that was published, whole, in order.
  static std::size_t check_messages(const test::ViewClient& client, const std::string& topic,
                                    const std::map<Nanos, Truth>& truth) {
    std::size_t n = 0;
    Nanos last = 0;
    for (const auto& m : client.events("message")) {
      if (m["topic"] != topic) continue;
      const Nanos stamp = std::stoll(m["stamp_ns"].get<std::string>());
      const auto it = truth.find(stamp);
      EXPECT_NE(it, truth.end()) << topic << ": a message with a stamp never published: " << stamp;
      if (it == truth.end()) continue;
      EXPECT_EQ(m["summary"]["data"]["len"].get<std::size_t>(), it->second.len) << topic;
      EXPECT_EQ(m["summary"]["data"]["fnv1a"].get<std::uint32_t>(), it->second.fnv) << topic;
      EXPECT_EQ(m["summary"]["header"]["frame_id"], "test");
      EXPECT_EQ(m["receive_ns"].get<std::string>(), std::to_string(stamp)) << "receive timestamp as published";
      EXPECT_GT(stamp, last) << topic << ": out of order";
      last = stamp;
      ++n;
    }
    return n;
  }

  std::unique_ptr<Server> server_;
  std::string url_;
  std::mutex mu_;
  std::vector<ChannelId> firsts_, lasts_;
};

TEST_F(ViewServer, TwoClientsGetEveryChannelTheySubscribeDecodedAsPublished) {
  const ChannelId a = server_->add_channel(blob_channel("/test/a"));
  const ChannelId b = server_->add_channel(blob_channel("/test/b"));
  Publisher pa(*server_, a, 1000, 50);
  Publisher pb(*server_, b, 200'000, 20);
  test::ViewClient c1({"--url", url_, "--subscribe", "/test/a,/test/b", "--count", "20", "--print-messages"});
  test::ViewClient c2({"--url", url_, "--subscribe", "/test/a,/test/b", "--count", "20", "--print-messages"});
  ASSERT_TRUE(c1.wait_exit(30'000)) << c1.transcript();
  ASSERT_TRUE(c2.wait_exit(30'000)) << c2.transcript();
  pa.stop();
  pb.stop();
  for (const auto* c : {&c1, &c2}) {
    EXPECT_EQ(c->exit_status(), 0) << c->transcript();
    const auto info = c->events("serverInfo");
    ASSERT_EQ(info.size(), 1u) << c->transcript();
    EXPECT_EQ(info[0]["name"], "sensor-rig");
    EXPECT_EQ(info[0]["capabilities"], json::array({"time"}));
    std::set<std::string> advertised;
    for (const auto& adv : c->events("advertise"))
      for (const auto& ch : adv["channels"]) {
        advertised.insert(ch["topic"].get<std::string>());
        EXPECT_EQ(ch["encoding"], "cdr");
        EXPECT_EQ(ch["schemaEncoding"], "ros2msg");
        EXPECT_EQ(ch["schemaName"], "sensor_rig_test/msg/Blob");
      }
    EXPECT_EQ(advertised, (std::set<std::string>{"/test/a", "/test/b"}));
    EXPECT_GE(check_messages(*c, "/test/a", pa.sent()), 20u) << c->transcript();
    EXPECT_GE(check_messages(*c, "/test/b", pb.sent()), 20u);
    EXPECT_TRUE(c->events("schema_error").empty() && c->events("decode_error").empty()) << c->transcript();
    EXPECT_TRUE(c->summary()["statuses"].empty()) << c->transcript();
    // `time` every 50 ms from the wall clock (the messages' timestamps' clock), never backwards.
    const json time = c->summary()["time"];
    EXPECT_GE(time["count"].get<int>(), 5) << time.dump();
    EXPECT_EQ(time["backwards"], 0);
    EXPECT_LT(std::abs(time["last_minus_now_ms"].get<double>()), 1000.0) << time.dump();
  }
  const auto st = server_->stats();
  EXPECT_EQ(st.protocol_errors, 0u);
  EXPECT_EQ(st.clients_accepted, 2u);
  // Each channel got its first subscriber once and lost its last one when both clients had gone.
  ASSERT_TRUE(test::wait_for([&] { return lasts().size() == 2; }, 30'000)) << lasts().size();
  const auto f = firsts();
  const auto l = lasts();
  EXPECT_EQ(std::set<ChannelId>(f.begin(), f.end()), (std::set<ChannelId>{a, b}));
  EXPECT_EQ(f.size(), 2u);
  EXPECT_EQ(std::set<ChannelId>(l.begin(), l.end()), (std::set<ChannelId>{a, b}));
}

TEST_F(ViewServer, ARemovedChannelIsUnadvertisedAndItsSubscriptionEnds) {
  const ChannelId a = server_->add_channel(blob_channel("/test/a"));
  const ChannelId b = server_->add_channel(blob_channel("/test/b"));
  Publisher pa(*server_, a, 100, 50);
  Publisher pb(*server_, b, 100, 50);
  test::ViewClient c({"--url", url_, "--subscribe-all", "--duration", "3", "--print-messages"});
  ASSERT_TRUE(test::wait_for(
      [&] {
        c.collect(10);
        return c.events("message").size() >= 10;
      },
      20'000))
      << c.transcript();
  server_->remove_channel(a);
  EXPECT_FALSE(server_->has_subscribers(a));
  ASSERT_TRUE(c.wait_exit(20'000)) << c.transcript();
  pa.stop();
  pb.stop();
  const auto un = c.events("unadvertise");
  ASSERT_EQ(un.size(), 1u) << c.transcript();
  EXPECT_EQ(un[0]["channelIds"], json::array({a}));
  // No message of `a` after its unadvertise, and `b` goes on.
  bool after = false;
  std::size_t b_after = 0;
  for (const auto& line : c.lines()) {
    if (line["event"] == "unadvertise") after = true;
    if (line["event"] != "message" || !after) continue;
    EXPECT_NE(line["topic"], "/test/a") << "a message of an unadvertised channel";
    if (line["topic"] == "/test/b") ++b_after;
  }
  EXPECT_GT(b_after, 10u);
  EXPECT_GE(check_messages(c, "/test/b", pb.sent()), b_after);
  // Removing a channel is the owner's doing: no last_unsubscribed callback for it.
  ASSERT_TRUE(test::wait_for([&] { return lasts().size() == 1; }, 30'000));
  EXPECT_EQ(lasts(), (std::vector<ChannelId>{b}));
}

// A client that stops reading (its socket paused: the kernel buffers fill, the server's write
// never completes) loses its oldest samples, counted; another client on the same channel gets every
// sample at the full rate, and publish() never waits for either.
TEST_F(ViewServer, AStalledClientLosesItsOldestAndAnotherKeepsTheFullRate) {
  const ChannelId big = server_->add_channel(blob_channel("/test/big"));
  Publisher p(*server_, big, 1'000'000, 20);
  test::ViewClient stalled({"--url", url_, "--subscribe", "/test/big", "--stall-after", "2", "--duration", "8",
                            "--timeout", "30"});
  ASSERT_TRUE(test::wait_for(
      [&] {
        stalled.collect(10);
        return !stalled.events("stalled").empty();
      },
      20'000))
      << stalled.transcript();
  // Let its buffers fill and its queue overflow before the second client comes.
  ASSERT_TRUE(test::wait_for(
      [&] {
        const auto st = server_->stats();
        return !st.clients.empty() && st.clients[0].dropped > 0;
      },
      20'000));
  test::ViewClient fast({"--url", url_, "--subscribe", "/test/big", "--duration", "4", "--print-messages"});
  ASSERT_TRUE(fast.wait_exit(30'000)) << fast.transcript();
  const auto st = server_->stats();  // the stalled one is still connected; the fast one gone
  ASSERT_EQ(st.clients.size(), 1u);
  const std::uint64_t stalled_drops = st.clients[0].dropped;
  EXPECT_LE(st.clients[0].messages_sent, 40u) << "the stalled client cannot have taken 20 Hz of 1 MB";
  p.stop();
  stalled.stop();

  EXPECT_EQ(fast.exit_status(), 0) << fast.transcript();
  const auto sent = p.sent();
  const std::size_t got = check_messages(fast, "/test/big", sent);
  const auto msgs = fast.events("message");
  ASSERT_GE(msgs.size(), 2u) << fast.transcript();
  const Nanos first = std::stoll(msgs.front()["stamp_ns"].get<std::string>());
  const Nanos last = std::stoll(msgs.back()["stamp_ns"].get<std::string>());
  const auto published = static_cast<std::size_t>(
      std::count_if(sent.begin(), sent.end(), [&](const auto& kv) { return kv.first >= first && kv.first <= last; }));
  // Every sample published between its first and last message reached it: the full rate (~20 Hz
  // for ~4 s), unaffected by the stalled client.
  EXPECT_EQ(got, published);
  EXPECT_GE(got, 50u);
  EXPECT_GT(stalled_drops, 10u) << "the stalled client's drops are counted";
  EXPECT_EQ(st.dropped, stalled_drops) << "all drops were the stalled client's";
  EXPECT_LT(p.max_publish_ns(), Nanos{100'000'000}) << "publish() waited for a client";
}

TEST_F(ViewServer, BadInputGetsAStatusErrorEachAndTheServerGoesOn) {
  const ChannelId a = server_->add_channel(blob_channel("/test/a"));
  Publisher pa(*server_, a, 100, 50);
  test::ViewClient bad({"--url", url_, "--bad-input", "--duration", "2", "--timeout", "20"});
  ASSERT_TRUE(bad.wait_exit(30'000)) << bad.transcript();
  std::vector<std::string> errors;
  const json summary = bad.summary();
  for (const auto& s : summary["statuses"])
    if (s["level"] == 2) errors.push_back(s["message"].get<std::string>());
  ASSERT_EQ(errors.size(), 9u) << bad.transcript();
  const char* const expected[] = {"not valid JSON", "JSON object", "missing \"op\"", "unknown op \"frobnicate\"",
                                  "no channel 4000000", "must be an array", "no subscription 777777",
                                  "capability", "binary client messages"};
  for (std::size_t i = 0; i < 9; ++i) EXPECT_NE(errors[i].find(expected[i]), std::string::npos) << errors[i];
  // The connection stayed open until the client itself ended it (after its summary).
  bool summarised = false;
  for (const auto& line : bad.lines()) {
    if (line["event"] == "summary") summarised = true;
    if (line["event"] == "close") {
      EXPECT_TRUE(summarised) << "the server closed the connection on bad input";
    }
  }

  // Not WebSocket at all, WebSocket without our subprotocol, and bytes that are not HTTP: refused.
  auto raw = [&](const std::string& request) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(server_->port());
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    std::string reply;
    if (::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) == 0 &&
        ::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(request.size())) {
      timeval tv{5, 0};
      ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      char buf[512];
      ssize_t n = 0;
      while ((n = ::recv(fd, buf, sizeof buf, 0)) > 0) reply.append(buf, static_cast<std::size_t>(n));
    }
    ::close(fd);
    return reply;
  };
  EXPECT_EQ(raw("GET / HTTP/1.1\r\nHost: x\r\n\r\n").rfind("HTTP/1.1 426", 0), 0u);
  EXPECT_EQ(raw("GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                "Sec-WebSocket-Protocol: something.else\r\n\r\n")
                .rfind("HTTP/1.1 400", 0),
            0u);
  EXPECT_EQ(raw(std::string("\x16\x03\x01\x00garbage\r\n\r\n", 14)), "");
  const auto st = server_->stats();
  EXPECT_EQ(st.protocol_errors, 9u);
  EXPECT_EQ(st.clients_rejected, 3u);

  test::ViewClient good({"--url", url_, "--subscribe", "/test/a", "--count", "10", "--print-messages"});
  ASSERT_TRUE(good.wait_exit(30'000)) << good.transcript();
  EXPECT_EQ(good.exit_status(), 0);
  EXPECT_GE(check_messages(good, "/test/a", pa.sent()), 10u);
}

TEST_F(ViewServer, StopSaysGoingAwayToItsClients) {
  server_->add_channel(blob_channel("/test/a"));
  test::ViewClient c({"--url", url_, "--subscribe-all", "--duration", "20", "--timeout", "30"});
  ASSERT_TRUE(test::wait_for([&] { return server_->stats().clients.size() == 1; }, 20'000)) << c.transcript();
  const Nanos t0 = monotonic_now_ns();
  server_->stop();
  EXPECT_LT(monotonic_now_ns() - t0, Nanos{2'000'000'000});
  ASSERT_TRUE(c.wait_exit(10'000)) << c.transcript();
  const auto closes = c.events("close");
  ASSERT_EQ(closes.size(), 1u) << c.transcript();
  EXPECT_EQ(closes[0]["code"], 1001) << "a WebSocket close, going away";
}

TEST(ViewServerOptions, LoopbackByDefaultAndBadAddressesRefused) {
  EXPECT_EQ(ServerOptions{}.address, "127.0.0.1");
  EXPECT_EQ(ServerOptions{}.port, 8765);
  ServerOptions o;
  o.address = "not-an-address";
  EXPECT_THROW(Server{o}, std::invalid_argument);
  ServerOptions a;
  a.port = 0;
  Server first(a);
  ServerOptions b;
  b.port = first.port();
  try {
    Server second(b);
    ADD_FAILURE() << "a second server on the same port";
  } catch (const std::system_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(first.port())), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sensor_rig::view
