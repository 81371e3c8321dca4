// E2E protection against published vectors: AUTOSAR CRC check values and E2E P01/P02 examples
// (the vectors of the autosar-e2e package's test suite), plus the receiver's counter logic.
#include <gtest/gtest.h>

#include <array>
#include <string_view>

#include "sensor_rig/dbw/safety/e2e.hpp"

namespace s = sensor_rig::dbw::safety;

namespace {

std::span<const std::uint8_t> bytes(std::string_view t) {
  return {reinterpret_cast<const std::uint8_t*>(t.data()), t.size()};
}

TEST(E2eCrc, AutosarCheckValues) {
  EXPECT_EQ(s::crc8_sae_j1850(bytes("123456789")), 0x4B);
  EXPECT_EQ(s::crc8h2f(bytes("123456789")), 0xDF);
  // AUTOSAR SWS_Crc tables: 00 00 00 00 -> 0x59 (J1850) / 0x12 (H2F); F2 01 83 -> 0x37 / 0xC2.
  const std::array<std::uint8_t, 4> z{};
  EXPECT_EQ(s::crc8_sae_j1850(z), 0x59);
  EXPECT_EQ(s::crc8h2f(z), 0x12);
  const std::array<std::uint8_t, 3> v{0xF2, 0x01, 0x83};
  EXPECT_EQ(s::crc8_sae_j1850(v), 0x37);
  EXPECT_EQ(s::crc8h2f(v), 0xC2);
  // Chaining: a split computation equals the whole.
  const auto whole = s::crc8_sae_j1850(bytes("123456789"));
  const auto part = s::crc8_sae_j1850(bytes("1234"));
  EXPECT_EQ(s::crc8_sae_j1850(bytes("56789"), part, false), whole);
}

s::E2eConfig p01(s::P01IdMode mode) {
  s::E2eConfig c;
  c.profile = s::E2eProfile::kP01;
  c.data_id = 0x123;
  c.id_mode = mode;
  return c;
}

TEST(E2eP01, PublishedVectors) {
  struct V {
    s::P01IdMode mode;
    std::uint8_t counter;
    std::array<std::uint8_t, 2> head;
  };
  const V vs[] = {{s::P01IdMode::kBoth, 0, {0xCC, 0x00}},   {s::P01IdMode::kBoth, 1, {0x91, 0x01}},
                  {s::P01IdMode::kAlt, 0, {0xCE, 0x00}},    {s::P01IdMode::kAlt, 1, {0x02, 0x01}},
                  {s::P01IdMode::kLow, 0, {0xCE, 0x00}},    {s::P01IdMode::kLow, 1, {0x93, 0x01}},
                  {s::P01IdMode::kNibble, 0, {0x2A, 0x10}}, {s::P01IdMode::kNibble, 1, {0x77, 0x11}}};
  for (const auto& v : vs) {
    std::array<std::uint8_t, 8> d{};
    ASSERT_TRUE(s::protect(p01(v.mode), d, v.counter));
    EXPECT_EQ(d[0], v.head[0]) << static_cast<int>(v.mode) << "/" << int(v.counter);
    EXPECT_EQ(d[1], v.head[1]) << static_cast<int>(v.mode) << "/" << int(v.counter);
    s::E2eChecker chk(p01(v.mode));
    EXPECT_EQ(chk.check(d), s::E2eStatus::kOk);
    d[1] ^= 0x20;  // corrupt the nibble/counter byte
    s::E2eChecker chk2(p01(v.mode));
    EXPECT_NE(chk2.check(d), s::E2eStatus::kOk);
  }
}

TEST(E2eP02, PublishedVectors) {
  s::E2eConfig c;
  c.profile = s::E2eProfile::kP02;
  std::array<std::uint8_t, 8> d{};
  ASSERT_TRUE(s::protect(c, d, 1));
  EXPECT_EQ(d, (std::array<std::uint8_t, 8>{0x45, 0x01, 0, 0, 0, 0, 0, 0}));
  for (std::uint8_t i = 0; i < 16; ++i) c.data_id_list[i] = i;
  d = {0, 1, 2, 3, 4, 5, 6, 7};
  ASSERT_TRUE(s::protect(c, d, 2));
  EXPECT_EQ(d, (std::array<std::uint8_t, 8>{0xBC, 0x02, 2, 3, 4, 5, 6, 7}));
  d = {0, 1, 2, 3, 4, 5, 6, 7};
  ASSERT_TRUE(s::protect(c, d, 1));
  EXPECT_EQ(d[0], 0x61);
  s::E2eChecker chk(c);
  const std::array<std::uint8_t, 8> good{0xBC, 0x02, 2, 3, 4, 5, 6, 7};
  const std::array<std::uint8_t, 8> bad{0xBC, 0x01, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(chk.check(good), s::E2eStatus::kOk);
  s::E2eChecker chk2(c);
  EXPECT_EQ(chk2.check(bad), s::E2eStatus::kBadCrc);
}

TEST(E2eChecker, CounterSequence) {
  for (auto profile : {s::E2eProfile::kCounter, s::E2eProfile::kJ1850, s::E2eProfile::kP01, s::E2eProfile::kP02}) {
    SCOPED_TRACE(std::string(s::to_string(profile)));
    s::E2eConfig c;
    c.profile = profile;
    c.data_id = 0x42;
    c.crc_byte = profile == s::E2eProfile::kP02 ? 0 : 7;
    c.counter_byte = 1;
    c.counter_high_nibble = profile == s::E2eProfile::kCounter;
    c.max_delta = 2;
    s::E2eSender tx(c);
    s::E2eChecker rx(c);
    const std::uint8_t mod = s::counter_modulus(profile);
    std::array<std::uint8_t, 8> d{};
    for (int i = 0; i < 40; ++i) {  // wraps around
      d[3] = static_cast<std::uint8_t>(i);
      ASSERT_TRUE(tx.protect(d));
      ASSERT_EQ(rx.check(d), s::E2eStatus::kOk) << i;
    }
    EXPECT_EQ(rx.check(d), s::E2eStatus::kRepeated);  // stuck counter
    ASSERT_TRUE(tx.protect(d));                       // lose one frame
    ASSERT_TRUE(tx.protect(d));
    EXPECT_EQ(rx.check(d), s::E2eStatus::kOkSomeLost);
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(tx.protect(d));
    EXPECT_EQ(rx.check(d), s::E2eStatus::kWrongSequence);
    ASSERT_TRUE(tx.protect(d));
    EXPECT_EQ(rx.check(d), s::E2eStatus::kOk);  // resynchronised
    if (s::has_crc(profile)) {
      ASSERT_TRUE(tx.protect(d));
      d[4] ^= 0x01;  // single bit flip in the payload
      EXPECT_EQ(rx.check(d), s::E2eStatus::kBadCrc);
    }
    EXPECT_LE(s::read_counter(c, d), mod - 1);
  }
}

TEST(E2eChecker, LayoutErrors) {
  s::E2eConfig c;
  c.profile = s::E2eProfile::kP01;
  c.crc_byte = 9;
  std::array<std::uint8_t, 8> d{};
  EXPECT_FALSE(s::protect(c, d, 0));
  s::E2eChecker chk(c);
  EXPECT_EQ(chk.check(d), s::E2eStatus::kBadLayout);
  c.crc_byte = 0;
  d[1] = 0x0F;  // counter 15 is invalid in profile 1
  s::E2eChecker chk2(c);
  EXPECT_EQ(chk2.check(d), s::E2eStatus::kBadLayout);
  c.crc_byte = 1;  // CRC and counter in the same byte
  EXPECT_FALSE(s::protect(c, d, 0));
  s::E2eProfile p{};
  EXPECT_TRUE(s::parse_profile("p02", p));
  EXPECT_EQ(p, s::E2eProfile::kP02);
  EXPECT_FALSE(s::parse_profile("p99", p));
}

}  // namespace
