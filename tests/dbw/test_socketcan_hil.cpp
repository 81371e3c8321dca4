// SocketCAN on a real (or virtual) interface. This machine's kernel has no AF_CAN: skipped with the
// reason. Where CAN exists, RIG_CAN_IFACE (default vcan0) names the interface to use.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "sensor_rig/dbw/can/transport.hpp"

namespace can = sensor_rig::dbw::can;

namespace {

std::string iface() {
  const char* e = std::getenv("RIG_CAN_IFACE");
  return e != nullptr ? e : "vcan0";
}

TEST(SocketCanHil, LoopbackBetweenTwoSockets) {
  std::unique_ptr<can::Transport> a;
  try {
    a = can::open_transport("socketcan:" + iface());
  } catch (const can::TransportError& e) {
    GTEST_SKIP() << "SocketCAN not usable here: " << e.what();
  }
  auto b = can::open_transport("socketcan:" + iface());
  can::Frame f;
  f.id = 0x321;
  f.len = 4;
  f.data = {1, 2, 3, 4};
  const auto before = sensor_rig::vehicle_now_ns();
  ASSERT_EQ(a->send(f), can::IoStatus::kOk);
  can::RxFrame rx;
  ASSERT_EQ(b->receive(rx, 1000), can::IoStatus::kOk);
  EXPECT_EQ(rx.frame, f);
  EXPECT_GE(rx.stamp, before);
  f.fd = true;
  f.len = 64;
  const auto st = a->send(f);
  EXPECT_TRUE(st == can::IoStatus::kOk || st == can::IoStatus::kInvalid) << can::to_string(st);
}

TEST(SocketCanHil, ReportsMissingKernelSupportClearly) {
  try {
    (void)can::open_transport("socketcan:" + iface());
    GTEST_SKIP() << "SocketCAN present: nothing to check about its absence";
  } catch (const can::TransportError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("socketcan:" + iface()), std::string::npos) << msg;
    EXPECT_NE(msg.find("socket(AF_CAN)"), std::string::npos) << msg;
  }
}

}  // namespace
