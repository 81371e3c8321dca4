// candump -L format: parse/format round trips, FD, RTR, error frames, malformed lines; wire structs.
#include <gtest/gtest.h>

#include <cstring>
#include <sstream>

#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/can/frame.hpp"

namespace can = sensor_rig::dbw::can;

namespace {

TEST(Candump, ParsesTheDocumentedForms) {
  can::LogRecord r;
  ASSERT_EQ(can::parse_candump_line("(1436509052.249713) can0 123#DEADBEEF", r), can::LineStatus::kOk);
  EXPECT_EQ(r.stamp, 1436509052249713000LL);
  EXPECT_EQ(r.stamp_text, "1436509052.249713");
  EXPECT_EQ(r.iface, "can0");
  EXPECT_EQ(r.frame.id, 0x123U);
  EXPECT_FALSE(r.frame.extended);
  ASSERT_EQ(r.frame.len, 4);
  EXPECT_EQ(r.frame.data[0], 0xDE);
  EXPECT_EQ(r.frame.data[3], 0xEF);

  ASSERT_EQ(can::parse_candump_line("(46408.584930) vcan1 12345678#00.11.22\r", r), can::LineStatus::kOk);
  EXPECT_TRUE(r.frame.extended);
  EXPECT_EQ(r.frame.id, 0x12345678U);
  EXPECT_EQ(r.frame.len, 3);
  EXPECT_EQ(r.stamp, 46408584930000LL);

  ASSERT_EQ(can::parse_candump_line("(1.5) can0 7FF##3" + std::string(24, 'A'), r), can::LineStatus::kOk);
  EXPECT_TRUE(r.frame.fd);
  EXPECT_TRUE(r.frame.brs);
  EXPECT_TRUE(r.frame.esi);
  EXPECT_EQ(r.frame.len, 12);
  EXPECT_EQ(r.stamp, 1'500'000'000LL);

  ASSERT_EQ(can::parse_candump_line("(1.000001) can0 123#R", r), can::LineStatus::kOk);
  EXPECT_TRUE(r.frame.rtr);
  ASSERT_EQ(can::parse_candump_line("(1.000001) can0 123#R4", r), can::LineStatus::kOk);
  EXPECT_EQ(r.frame.len, 4);
  ASSERT_EQ(can::parse_candump_line("(1.000001) can0 20000080#0000000000000000", r), can::LineStatus::kOk);
  EXPECT_TRUE(r.frame.error);
  EXPECT_EQ(r.frame.id, 0x80U);
  ASSERT_EQ(can::parse_candump_line("(1.000001) can0 123# T", r), can::LineStatus::kOk);
  EXPECT_EQ(r.frame.len, 0);
  EXPECT_EQ(can::parse_candump_line("   ", r), can::LineStatus::kBlank);
}

TEST(Candump, RejectsMalformedLines) {
  can::LogRecord r;
  for (const char* bad : {"123#00", "(1.0 can0 123#00", "(1.0) can0", "(1.0) can0 1234#00", "(1.0) can0 800#00",
                          "(1.0) can0 123#0", "(1.0) can0 123#001122334455667788", "(x.0) can0 123#00",
                          "(1.0) can0 123##", "(1.0) can0 123##0112233445566778899", "(1.0) can0 123#GG",
                          "(1.0) can0 4FFFFFFF#00", "(1.0) can0 123#R9", "(1.0123456789) can0 123#00"}) {
    EXPECT_EQ(can::parse_candump_line(bad, r), can::LineStatus::kMalformed) << bad;
  }
}

TEST(Candump, FormatParseRoundTrip) {
  std::vector<can::Frame> frames;
  can::Frame a;
  a.id = 0x25;
  a.len = 8;
  for (int i = 0; i < 8; ++i) a.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(0x10 * i + 1);
  frames.push_back(a);
  can::Frame b = a;
  b.extended = true;
  b.id = 0x1ABCDEF0;
  b.len = 0;
  frames.push_back(b);
  can::Frame c;
  c.fd = true;
  c.brs = true;
  c.id = 0x100;
  c.len = 64;
  for (std::size_t i = 0; i < 64; ++i) c.data[i] = static_cast<std::uint8_t>(i);
  frames.push_back(c);
  can::Frame d;
  d.rtr = true;
  d.id = 0x7FF;
  d.len = 2;
  frames.push_back(d);
  can::Frame e;
  e.error = true;
  e.id = 0x40;
  e.len = 8;
  e.data[1] = 0x10;
  frames.push_back(e);
  std::string text;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    text += can::format_candump_line(1'700'000'000'123'456'000LL + static_cast<long long>(i) * 1000, "can0", frames[i]);
    text += "\n";
  }
  EXPECT_EQ(text.substr(0, text.find('\n')), "(1700000000.123456) can0 025#0111213141516171");
  text += "garbage line\n";
  std::istringstream in(text);
  can::CandumpReader reader(in);
  can::LogRecord r;
  std::size_t n = 0;
  while (reader.next(r)) {
    ASSERT_LT(n, frames.size());
    EXPECT_EQ(r.frame, frames[n]) << n;
    EXPECT_EQ(r.stamp, 1'700'000'000'123'456'000LL + static_cast<long long>(n) * 1000);
    ++n;
  }
  EXPECT_EQ(n, frames.size());
  EXPECT_EQ(reader.malformed(), 1U);
  EXPECT_EQ(reader.first_bad_line(), frames.size() + 1);
}

TEST(CanWire, KernelStructRoundTrip) {
  std::array<std::uint8_t, can::kFdWireSize> buf{};
  can::Frame f;
  f.id = 0x123;
  f.len = 3;
  f.data = {1, 2, 3};
  ASSERT_EQ(can::to_wire(f, buf), can::kClassicWireSize);
  // struct can_frame: can_id (host order), len, pad, res, len8_dlc, data aligned at 8.
  std::uint32_t id = 0;
  std::memcpy(&id, buf.data(), 4);
  EXPECT_EQ(id, 0x123U);
  EXPECT_EQ(buf[4], 3);
  EXPECT_EQ(buf[8], 1);
  can::Frame back;
  ASSERT_EQ(can::from_wire(std::span(buf.data(), can::kClassicWireSize), back), can::WireStatus::kOk);
  EXPECT_EQ(back, f);

  f.extended = true;
  f.id = 0x1FFFFFFF;
  f.fd = true;
  f.esi = true;
  f.len = 48;
  ASSERT_EQ(can::to_wire(f, buf), can::kFdWireSize);
  std::memcpy(&id, buf.data(), 4);
  EXPECT_EQ(id, 0x9FFFFFFFU);  // CAN_EFF_FLAG
  ASSERT_EQ(can::from_wire(buf, back), can::WireStatus::kOk);
  EXPECT_EQ(back, f);

  EXPECT_EQ(can::from_wire(std::span(buf.data(), 10), back), can::WireStatus::kBadSize);
  buf[4] = 65;
  EXPECT_EQ(can::from_wire(buf, back), can::WireStatus::kBadLength);
  can::Frame too_long;
  too_long.len = 9;
  EXPECT_EQ(can::to_wire(too_long, buf), 0U);
}

}  // namespace
