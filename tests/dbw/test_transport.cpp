// CAN transports over real sockets: socketpair, the unix-listen bus with several peers, replay timing.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>

#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace can = sensor_rig::dbw::can;
namespace fs = std::filesystem;

namespace {

can::Frame frame(std::uint32_t id, std::uint8_t len, bool fd = false) {
  can::Frame f;
  f.id = id;
  f.len = len;
  f.fd = fd;
  for (std::size_t i = 0; i < len; ++i) f.data[i] = static_cast<std::uint8_t>(id + i);
  return f;
}

std::string temp_path(const char* name) {
  return (fs::temp_directory_path() / (std::string(name) + "_" + std::to_string(::getpid()))).string();
}

TEST(Transport, SocketpairCarriesClassicAndFdWithKernelStamps) {
  auto [a, b] = can::make_socketpair();
  const auto before = sensor_rig::vehicle_now_ns();
  ASSERT_EQ(a->send(frame(0x123, 8)), can::IoStatus::kOk);
  ASSERT_EQ(a->send(frame(0x456, 64, true)), can::IoStatus::kOk);
  can::RxFrame rx;
  ASSERT_EQ(b->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame, frame(0x123, 8));
  EXPECT_GE(rx.stamp, before);
  EXPECT_LE(rx.stamp, sensor_rig::vehicle_now_ns());
  ASSERT_EQ(b->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame, frame(0x456, 64, true));
  EXPECT_EQ(b->receive(rx, 10), can::IoStatus::kTimeout);
  EXPECT_EQ(a->stats().sent, 2U);
  EXPECT_EQ(b->stats().received, 2U);
  EXPECT_EQ(a->stats().options_refused, 0U);
  EXPECT_EQ(b->stats().options_refused, 0U);
  can::Frame bad = frame(1, 8);
  bad.len = 9;
  EXPECT_EQ(a->send(bad), can::IoStatus::kInvalid);
  a.reset();
  EXPECT_EQ(b->receive(rx, 100), can::IoStatus::kClosed);
  EXPECT_EQ(b->send(frame(1, 1)), can::IoStatus::kClosed);
}

TEST(Transport, BusOffRefusesSendsUntilRestart) {
  auto [ecu, bridge] = can::make_socketpair();
  ASSERT_EQ(ecu->send(can::make_error_frame(true, false)), can::IoStatus::kOk);
  can::RxFrame rx;
  ASSERT_EQ(bridge->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_TRUE(rx.frame.error);
  EXPECT_EQ(bridge->bus_state(), can::BusState::kBusOff);
  EXPECT_EQ(bridge->send(frame(0x10, 2)), can::IoStatus::kBusOff);  // refused, not queued
  ASSERT_EQ(ecu->send(can::make_error_frame(false, true)), can::IoStatus::kOk);
  ASSERT_EQ(bridge->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(bridge->bus_state(), can::BusState::kActive);
  ASSERT_EQ(bridge->send(frame(0x11, 2)), can::IoStatus::kOk);
  ASSERT_EQ(ecu->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x11U);  // the refused frame never went out
  EXPECT_EQ(ecu->receive(rx, 20), can::IoStatus::kTimeout);
  EXPECT_EQ(bridge->stats().bus_off_events, 1U);
}

TEST(Transport, ListeningBusRelaysBetweenAllPeers) {
  const std::string path = temp_path("canbus");
  auto bus = can::open_transport("unix-listen:" + path);
  auto p1 = can::open_transport("unix:" + path);
  auto p2 = can::open_transport("unix:" + path);
  can::RxFrame rx;
  ASSERT_EQ(p1->send(frame(0x1, 1)), can::IoStatus::kOk);
  ASSERT_EQ(bus->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x1U);
  ASSERT_EQ(p2->receive(rx, 1000), can::IoStatus::kOk);  // a sniffer sees other peers' frames
  EXPECT_EQ(rx.frame.id, 0x1U);
  EXPECT_EQ(p1->receive(rx, 20), can::IoStatus::kTimeout);  // no echo to the sender
  ASSERT_EQ(bus->send(frame(0x2, 2)), can::IoStatus::kOk);
  ASSERT_EQ(p1->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x2U);
  ASSERT_EQ(p2->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x2U);
  p2.reset();  // a peer leaving does not disturb the bus
  ASSERT_EQ(bus->send(frame(0x3, 3)), can::IoStatus::kOk);
  ASSERT_EQ(p1->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x3U);
  EXPECT_EQ(bus->receive(rx, 20), can::IoStatus::kTimeout);
  bus.reset();
  EXPECT_FALSE(fs::exists(path));
  EXPECT_THROW(can::open_transport("unix:" + path), can::TransportError);
}

// The mock ECU (the bus owner) killed and restarted under `rig chaos` (host.kill_mock): a peer does not
// die with it, as a node on a real CAN bus would not. It reads bus-off while the owner is gone (sends
// refused: the bridge disengages), and is back on the bus, frames flowing, once the owner returns.
TEST(Transport, APeerOutlivesTheBusOwnerAndRejoinsWhenItReturns) {
  const std::string path = temp_path("canbus_restart");
  auto bus = can::open_transport("unix-listen:" + path);
  auto peer = can::open_transport("unix:" + path);
  can::RxFrame rx;
  ASSERT_EQ(bus->send(frame(0x10, 1)), can::IoStatus::kOk);
  ASSERT_EQ(peer->receive(rx, 1000), can::IoStatus::kOk);
  // A bus-off the bus reports (an error frame) is not a lost connection: it holds until the restart.
  ASSERT_EQ(bus->send(can::make_error_frame(true, false)), can::IoStatus::kOk);
  ASSERT_EQ(peer->receive(rx, 1000), can::IoStatus::kOk);
  ASSERT_EQ(peer->bus_state(), can::BusState::kBusOff);
  EXPECT_EQ(peer->receive(rx, 300), can::IoStatus::kTimeout);
  EXPECT_EQ(peer->bus_state(), can::BusState::kBusOff) << "no reconnect clears a reported bus-off";
  EXPECT_EQ(peer->send(frame(0x1F, 1)), can::IoStatus::kBusOff);
  ASSERT_EQ(bus->send(can::make_error_frame(false, true)), can::IoStatus::kOk);
  ASSERT_EQ(peer->receive(rx, 1000), can::IoStatus::kOk);
  ASSERT_EQ(peer->bus_state(), can::BusState::kActive);
  bus.reset();  // the ECU died
  EXPECT_EQ(peer->receive(rx, 200), can::IoStatus::kTimeout) << "not kClosed: the bus is still there";
  EXPECT_EQ(peer->bus_state(), can::BusState::kBusOff);
  EXPECT_EQ(peer->send(frame(0x11, 1)), can::IoStatus::kBusOff);
  EXPECT_EQ(peer->stats().bus_off_events.load(), 2U) << "the reported one, then the lost connection";
  bus = can::open_transport("unix-listen:" + path);  // restarted
  const auto t0 = std::chrono::steady_clock::now();
  while (peer->bus_state() == can::BusState::kBusOff && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5))
    (void)peer->receive(rx, 20);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500)) << "reconnects every 100 ms";
  ASSERT_EQ(peer->bus_state(), can::BusState::kActive);
  ASSERT_EQ(peer->send(frame(0x12, 2)), can::IoStatus::kOk);
  ASSERT_EQ(bus->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x12U);
  ASSERT_EQ(bus->send(frame(0x13, 3)), can::IoStatus::kOk);
  ASSERT_EQ(peer->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x13U);
  // An inherited descriptor has nothing to reconnect to: its end is the end.
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv), 0);
  auto a = can::open_transport("fd:" + std::to_string(sv[0]));
  ::close(sv[1]);
  EXPECT_EQ(a->receive(rx, 200), can::IoStatus::kClosed);
}

TEST(Transport, ListeningBusSendsAndReceivesFromTwoThreadsWhilePeersComeAndGo) {
  // The bridge sends from two threads while a third receives; peers join and leave meanwhile.
  const std::string path = temp_path("canbus_mt");
  auto bus = can::open_transport("unix-listen:" + path);
  auto talker = can::open_transport("unix:" + path);
  std::atomic<bool> stop{false};
  std::atomic<int> received{0};
  std::thread rx_thread([&] {
    can::RxFrame rx;
    while (!stop) {
      if (bus->receive(rx, 2) == can::IoStatus::kOk) ++received;
    }
  });
  std::thread churn([&] {
    for (int i = 0; i < 50 && !stop; ++i) {
      auto p = can::open_transport("unix:" + path);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  int sent = 0;
  for (int i = 0; i < 500; ++i) {
    if (bus->send(frame(0x10, 1)) == can::IoStatus::kOk) ++sent;
    if (i % 5 == 0) talker->send(frame(0x11, 1));
  }
  churn.join();
  for (int i = 0; i < 200 && received < 100; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  stop = true;
  rx_thread.join();
  EXPECT_EQ(sent, 500);
  EXPECT_EQ(received, 100);
  EXPECT_EQ(bus->stats().sent, 500U);
  EXPECT_EQ(bus->stats().received, 100U);
}

TEST(Transport, InheritedDescriptorSpec) {
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  auto a = can::open_transport("fd:" + std::to_string(sv[0]));
  auto b = can::open_transport("socketpair:" + std::to_string(sv[1]));
  ASSERT_EQ(a->send(frame(0x7, 7)), can::IoStatus::kOk);
  can::RxFrame rx;
  ASSERT_EQ(b->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame, frame(0x7, 7));
}

TEST(Transport, OptionalSocketOptionTheKernelRefusesIsCountedNotFatal) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);  // not a socket: SO_TIMESTAMPNS fails with ENOTSOCK
  ::close(p[1]);
  auto t = can::open_transport("fd:" + std::to_string(p[0]));  // logs a warning
  EXPECT_EQ(t->stats().options_refused, 1U);
  EXPECT_EQ(t->stats().last_errno, ENOTSOCK);
}

TEST(Transport, BadSpecsThrowClearErrors) {
  for (const char* s : {"", "can0", "bogus:x", "fd:abc", "fd:", "candump:/nonexistent/log", "candump:/tmp/x@fast",
                        "candump:/tmp/x@-1", "candump:/tmp/x@1,", "candump:/tmp/x@1,soon", "nokind:/tmp/x@1"}) {
    EXPECT_THROW((void)can::open_transport(s), can::TransportError) << s;
  }
}

TEST(Transport, ReplayKeepsRecordedTiming) {
  const std::string path = temp_path("replay.log");
  {
    std::ofstream out(path);
    out << can::format_candump_line(1'000'000'000'000'000'000LL, "can0", frame(0x10, 1)) << "\n";
    out << "not a frame\n";
    out << can::format_candump_line(1'000'000'000'060'000'000LL, "can0", frame(0x11, 1)) << "\n";
    out << can::format_candump_line(1'000'000'000'120'000'000LL, "can1", frame(0x12, 1)) << "\n";
  }
  auto t = can::open_transport("candump:" + path);
  can::RxFrame rx;
  const auto t0 = sensor_rig::monotonic_now_ns();
  ASSERT_EQ(t->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.stamp, 1'000'000'000'000'000'000LL);
  EXPECT_EQ(t->receive(rx, 5), can::IoStatus::kTimeout);  // next one is 60 ms later
  ASSERT_EQ(t->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x11U);
  const auto dt1 = sensor_rig::monotonic_now_ns() - t0;
  ASSERT_EQ(t->receive(rx, 1000), can::IoStatus::kOk);
  const auto dt2 = sensor_rig::monotonic_now_ns() - t0;
  EXPECT_GE(dt1, 59'000'000);
  EXPECT_LT(dt1, 90'000'000);
  EXPECT_GE(dt2, 119'000'000);
  EXPECT_LT(dt2, 160'000'000);
  EXPECT_EQ(t->receive(rx, 10), can::IoStatus::kClosed);
  EXPECT_EQ(t->stats().rx_dropped, 1U);

  auto fast = can::open_transport("candump:" + path + "@0");
  const auto f0 = sensor_rig::monotonic_now_ns();
  int n = 0;
  while (fast->receive(rx, 1000) == can::IoStatus::kOk) ++n;
  EXPECT_EQ(n, 3);
  EXPECT_LT(sensor_rig::monotonic_now_ns() - f0, 30'000'000);

  // @RATE,DELAY_S: the first frame DELAY_S after the first receive(), the others at their spacing.
  auto late = can::open_transport("candump:" + path + "@1,0.2");
  const auto l0 = sensor_rig::monotonic_now_ns();
  EXPECT_EQ(late->receive(rx, 5), can::IoStatus::kTimeout);
  ASSERT_EQ(late->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame.id, 0x10U);
  EXPECT_GE(sensor_rig::monotonic_now_ns() - l0, 199'000'000);
  ASSERT_EQ(late->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_GE(sensor_rig::monotonic_now_ns() - l0, 259'000'000);
  fs::remove(path);
}

// A log kind registered from above (the rig registers mcap:): KIND:FILE[@RATE[,DELAY_S]] replays
// its frames at their recorded timing, stamped with their recorded receive times; its own default delay.
class ListLog final : public can::FrameLog {
 public:
  explicit ListLog(const std::string& file) : file_(file) {}
  bool next(can::LoggedFrame& out) override {
    if (i_ == 3) return false;
    out.stamp = 5'000'000'000LL + static_cast<sensor_rig::Nanos>(i_) * 20'000'000;
    out.frame = frame(static_cast<std::uint32_t>(0x20 + i_), 1);
    ++i_;
    return true;
  }
  [[nodiscard]] std::uint64_t malformed() const override { return file_ == "bad" ? 2 : 0; }
  [[nodiscard]] sensor_rig::Nanos default_delay_ns() const override { return 30'000'000; }

 private:
  std::string file_;
  int i_ = 0;
};

TEST(Transport, RegisteredLogKindReplaysItsFrames) {
  can::register_frame_log_kind("listlog", [](const std::string& f) -> std::unique_ptr<can::FrameLog> {
    if (f == "missing") throw std::runtime_error("no such log");
    return std::make_unique<ListLog>(f);
  });
  try {
    (void)can::open_transport("listlog:missing");
    ADD_FAILURE() << "opened";
  } catch (const can::TransportError& e) {
    EXPECT_NE(std::string(e.what()).find("listlog:missing: no such log"), std::string::npos) << e.what();
  }
  auto t = can::open_transport("listlog:bad");
  EXPECT_EQ(t->name(), "listlog:bad");
  can::RxFrame rx;
  const auto t0 = sensor_rig::monotonic_now_ns();
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(t->receive(rx, 1000), can::IoStatus::kOk) << i;
    EXPECT_EQ(rx.frame.id, 0x20U + static_cast<unsigned>(i));
    EXPECT_EQ(rx.stamp, 5'000'000'000LL + i * 20'000'000LL);
    EXPECT_GE(sensor_rig::monotonic_now_ns() - t0, 29'000'000 + i * 20'000'000LL) << i;  // default delay 30 ms
  }
  EXPECT_EQ(t->receive(rx, 10), can::IoStatus::kClosed);
  EXPECT_EQ(t->stats().rx_dropped, 2U);
  auto fast = can::open_transport("listlog:x@0,0");
  const auto f0 = sensor_rig::monotonic_now_ns();
  while (fast->receive(rx, 1000) == can::IoStatus::kOk) {
  }
  EXPECT_LT(sensor_rig::monotonic_now_ns() - f0, 20'000'000);
}

}  // namespace
