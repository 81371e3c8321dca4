// Signal codec: bit layouts checked against an independent reference, real frames, round trips.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "sensor_rig/dbw/dbc/codec.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace dbc = sensor_rig::dbw::dbc;

namespace {

dbc::Signal sig(int start, int len, dbc::ByteOrder order, bool is_signed = false, double factor = 1.0,
                double offset = 0.0) {
  dbc::Signal s;
  s.name = std::string(1, 'S');  // not = "S": GCC 12 -O3 reports a false -Wrestrict on that assign
  s.start_bit = static_cast<std::uint16_t>(start);
  s.length = static_cast<std::uint16_t>(len);
  s.order = order;
  s.is_signed = is_signed;
  s.factor = factor;
  s.offset = offset;
  return s;
}

// Reference: Motorola as a contiguous range in MSB-first ("big-endian") bit numbering, where index j
// is byte j/8, bit 7 - j%8. The DBC start bit is converted to that numbering. Intel: LSB-first.
std::vector<int> reference_positions(const dbc::Signal& s) {
  std::vector<int> pos;  // MSB first
  if (s.order == dbc::ByteOrder::kMotorola) {
    const int msb = (s.start_bit / 8) * 8 + (7 - s.start_bit % 8);
    for (int j = msb; j < msb + s.length; ++j) pos.push_back((j / 8) * 8 + (7 - j % 8));
  } else {
    for (int i = s.length - 1; i >= 0; --i) pos.push_back(s.start_bit + i);
  }
  return pos;
}

std::uint64_t reference_extract(const dbc::Signal& s, const std::vector<std::uint8_t>& d) {
  std::uint64_t raw = 0;
  for (int p : reference_positions(s)) raw = (raw << 1) | ((d[static_cast<std::size_t>(p / 8)] >> (p % 8)) & 1U);
  return raw;
}

TEST(DbcCodec, MotorolaBitNumberingEdgeCases) {
  const std::vector<std::uint8_t> d = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0xDE, 0xF0};
  // 16 bits from bit 7: bytes 0..1 big endian.
  EXPECT_EQ(*dbc::extract_raw(sig(7, 16, dbc::ByteOrder::kMotorola), d), 0x1234U);
  // Start at bit 0 of byte 0, 8 bits: bit 0 of byte 0 then bits 7..1 of byte 1.
  EXPECT_EQ(*dbc::extract_raw(sig(0, 8, dbc::ByteOrder::kMotorola), d), ((0x12U & 1U) << 7) | (0x34U >> 1));
  // Nibble start (3|12): low nibble of byte 0 + byte 1.
  EXPECT_EQ(*dbc::extract_raw(sig(3, 12, dbc::ByteOrder::kMotorola), d), 0x234U);
  // Single bit at 7 and at 0.
  EXPECT_EQ(*dbc::extract_raw(sig(7, 1, dbc::ByteOrder::kMotorola), d), 0U);
  EXPECT_EQ(*dbc::extract_raw(sig(4, 1, dbc::ByteOrder::kMotorola), d), 1U);
  // All 64 bits from bit 7.
  EXPECT_EQ(*dbc::extract_raw(sig(7, 64, dbc::ByteOrder::kMotorola), d), 0x123456789ABCDEF0ULL);
  // Last byte only (start 63).
  EXPECT_EQ(*dbc::extract_raw(sig(63, 8, dbc::ByteOrder::kMotorola), d), 0xF0U);
  // Running off the end of the frame: start 56, 9 bits needs a 9th byte.
  EXPECT_FALSE(dbc::extract_raw(sig(56, 9, dbc::ByteOrder::kMotorola), d).has_value());
  EXPECT_FALSE(dbc::signal_fits(sig(56, 9, dbc::ByteOrder::kMotorola), 8));
  EXPECT_TRUE(dbc::signal_fits(sig(56, 9, dbc::ByteOrder::kMotorola), 9));
  // Intel across bytes and the 9-byte span of a 64-bit signal at an odd start (FD frames).
  EXPECT_EQ(*dbc::extract_raw(sig(4, 12, dbc::ByteOrder::kIntel), d), 0x341U);
  std::vector<std::uint8_t> fd(64, 0);
  for (std::size_t i = 0; i < fd.size(); ++i) fd[i] = static_cast<std::uint8_t>(i * 37 + 11);
  const auto s64 = sig(4, 64, dbc::ByteOrder::kIntel);
  EXPECT_EQ(*dbc::extract_raw(s64, fd), reference_extract(s64, fd));
  EXPECT_EQ(dbc::signal_extent(sig(511, 8, dbc::ByteOrder::kMotorola)), 64U);
  EXPECT_EQ(dbc::signal_extent(sig(505, 8, dbc::ByteOrder::kIntel)), 0U);  // beyond 64 bytes
}

TEST(DbcCodec, RealToyotaFrames) {
  const auto db = dbc::parse(R"(
BO_ 37 STEER_ANGLE_SENSOR: 8 XXX
 SG_ STEER_ANGLE : 3|12@0- (1.5,0) [-500|500] "deg" XXX
 SG_ STEER_FRACTION : 39|4@0- (0.1,0) [-0.7|0.7] "deg" XXX
 SG_ STEER_RATE : 35|12@0- (1,0) [-2000|2000] "deg/s" XXX
BO_ 170 WHEEL_SPEEDS: 8 XXX
 SG_ WHEEL_SPEED_FR : 6|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_FL : 22|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RR : 38|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RL : 54|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
)");
  // (46408.584959) can0 025#00001000C00000FD
  const std::array<std::uint8_t, 8> steer = {0x00, 0x00, 0x10, 0x00, 0xC0, 0x00, 0x00, 0xFD};
  const auto& m = *db.find(37, false);
  EXPECT_DOUBLE_EQ(*dbc::decode(*m.find("STEER_ANGLE"), steer), 0.0);
  EXPECT_DOUBLE_EQ(*dbc::decode(*m.find("STEER_FRACTION"), steer), -0.4);
  EXPECT_EQ(dbc::format_value(*m.find("STEER_FRACTION"), *dbc::decode(*m.find("STEER_FRACTION"), steer)), "-0.4");
  // (46408.589503) can0 0AA#25B525B525A0258D
  const std::array<std::uint8_t, 8> w = {0x25, 0xB5, 0x25, 0xB5, 0x25, 0xA0, 0x25, 0x8D};
  const auto& wm = *db.find(170, false);
  EXPECT_EQ(dbc::format_value(*wm.find("WHEEL_SPEED_FR"), *dbc::decode(*wm.find("WHEEL_SPEED_FR"), w)), "28.86");
  EXPECT_EQ(dbc::format_value(*wm.find("WHEEL_SPEED_RR"), *dbc::decode(*wm.find("WHEEL_SPEED_RR"), w)), "28.65");
  EXPECT_EQ(dbc::format_value(*wm.find("WHEEL_SPEED_RL"), *dbc::decode(*wm.find("WHEEL_SPEED_RL"), w)), "28.46");
}

TEST(DbcCodec, RandomLayoutsMatchReferenceAndRoundTrip) {
  std::mt19937_64 rng(42);
  for (int iter = 0; iter < 20000; ++iter) {
    const std::size_t bytes = (iter % 3 == 0) ? 64 : 8;
    const int len = static_cast<int>(rng() % 64) + 1;
    const auto order = (rng() & 1U) != 0 ? dbc::ByteOrder::kIntel : dbc::ByteOrder::kMotorola;
    const int start = static_cast<int>(rng() % (bytes * 8));
    dbc::Signal s = sig(start, len, order, (rng() & 1U) != 0);
    std::vector<std::uint8_t> d(bytes);
    for (auto& b : d) b = static_cast<std::uint8_t>(rng());
    const bool fits = dbc::signal_fits(s, bytes);
    const auto ref = reference_positions(s);
    bool ref_fits = true;
    for (int p : ref) ref_fits = ref_fits && p >= 0 && p < static_cast<int>(bytes * 8);
    // The Motorola reference range may wrap below bit 0 differently; only compare where both agree it fits.
    ASSERT_EQ(fits, ref_fits) << start << "|" << len << (order == dbc::ByteOrder::kIntel ? "@1" : "@0");
    if (!fits) {
      EXPECT_FALSE(dbc::extract_raw(s, d).has_value());
      std::vector<std::uint8_t> copy = d;
      EXPECT_FALSE(dbc::insert_raw(s, 1, copy));
      EXPECT_EQ(copy, d);
      continue;
    }
    ASSERT_EQ(*dbc::extract_raw(s, d), reference_extract(s, d));
    // Insert a random raw value: read back equal, other bits untouched.
    const std::uint64_t mask = len == 64 ? ~0ULL : ((1ULL << len) - 1);
    const std::uint64_t raw = rng() & mask;
    std::vector<std::uint8_t> out = d;
    ASSERT_TRUE(dbc::insert_raw(s, raw, out));
    ASSERT_EQ(*dbc::extract_raw(s, out), raw);
    std::vector<bool> owned(bytes * 8, false);
    for (int p : ref) owned[static_cast<std::size_t>(p)] = true;
    for (std::size_t p = 0; p < bytes * 8; ++p) {
      if (!owned[p]) {
        ASSERT_EQ((out[p / 8] >> (p % 8)) & 1U, (d[p / 8] >> (p % 8)) & 1U) << "bit " << p;
      }
    }
  }
}

TEST(DbcCodec, PhysicalRoundTripAndClamping) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int iter = 0; iter < 5000; ++iter) {
    const int len = static_cast<int>(rng() % 32) + 2;
    const bool sgn = (rng() & 1U) != 0;
    const double factor = std::pow(10.0, -static_cast<int>(rng() % 4)) * (1 + static_cast<int>(rng() % 3));
    const double offset = static_cast<double>(static_cast<int>(rng() % 200) - 100);
    const auto s = sig(static_cast<int>(rng() % 8) + 56, len, dbc::ByteOrder::kMotorola, sgn, factor, offset);
    if (!dbc::signal_fits(s, 64)) continue;
    const double lo_raw = sgn ? -std::ldexp(1.0, len - 1) : 0.0;
    const double hi_raw = sgn ? std::ldexp(1.0, len - 1) - 1 : std::ldexp(1.0, len) - 1;
    const double phys = offset + factor * (lo_raw + u(rng) * (hi_raw - lo_raw));
    std::array<std::uint8_t, 64> d{};
    ASSERT_EQ(dbc::encode(s, phys, d), dbc::EncodeStatus::kOk);
    EXPECT_NEAR(*dbc::decode(s, d), phys, factor / 2 + 1e-9 * std::fabs(phys));
    // Beyond the representable range: clamped to the extreme, and said so.
    ASSERT_EQ(dbc::encode(s, offset + factor * (hi_raw + 10), d), dbc::EncodeStatus::kClamped);
    EXPECT_NEAR(*dbc::decode(s, d), offset + factor * hi_raw, 1e-9 * std::fabs(offset + factor * hi_raw) + 1e-12);
    ASSERT_EQ(dbc::encode(s, offset + factor * (lo_raw - 10), d), dbc::EncodeStatus::kClamped);
    EXPECT_NEAR(*dbc::decode(s, d), offset + factor * lo_raw, 1e-9 * std::fabs(offset + factor * lo_raw) + 1e-12);
  }
  std::array<std::uint8_t, 8> d{};
  const auto s = sig(0, 8, dbc::ByteOrder::kIntel);
  EXPECT_EQ(dbc::encode(s, std::nan(""), d), dbc::EncodeStatus::kNotFinite);
  EXPECT_EQ(dbc::encode(s, std::numeric_limits<double>::infinity(), d), dbc::EncodeStatus::kNotFinite);
  const auto s64 = sig(7, 64, dbc::ByteOrder::kMotorola, true);
  EXPECT_EQ(dbc::encode(s64, -1.0, d), dbc::EncodeStatus::kOk);
  EXPECT_EQ(*dbc::extract_raw(s64, d), ~0ULL);
  EXPECT_EQ(dbc::encode(s64, 1e30, d), dbc::EncodeStatus::kClamped);
  const auto u64 = sig(0, 64, dbc::ByteOrder::kIntel, false);
  EXPECT_EQ(dbc::encode(u64, 1e30, d), dbc::EncodeStatus::kClamped);
  EXPECT_GT(*dbc::extract_raw(u64, d), 0xFFFFFFFFFFFF0000ULL);
  std::array<std::uint8_t, 4> small{};
  EXPECT_EQ(dbc::encode(u64, 1.0, small), dbc::EncodeStatus::kOutOfFrame);
}

TEST(DbcCodec, FloatSignalsAndMultiplexing) {
  const auto db = dbc::parse(R"(
BO_ 10 M: 16 X
 SG_ Sel M : 0|8@1+ (1,0) [0|0] "" X
 SG_ F m1 : 8|32@1- (1,0) [0|0] "" X
 SG_ I m2 : 8|16@1- (0.5,0) [0|0] "" X
 SG_ D : 64|64@1- (2,1) [0|0] "" X
SIG_VALTYPE_ 10 F : 1;
SIG_VALTYPE_ 10 D : 2;
)");
  const auto& m = *db.find(10, false);
  std::array<std::uint8_t, 16> d{};
  ASSERT_EQ(dbc::encode(*m.find("Sel"), 1, d), dbc::EncodeStatus::kOk);
  ASSERT_EQ(dbc::encode(*m.find("F"), -3.25, d), dbc::EncodeStatus::kOk);
  ASSERT_EQ(dbc::encode(*m.find("D"), 1.0 + 2.0 * 3.141592653589793, d), dbc::EncodeStatus::kOk);
  EXPECT_DOUBLE_EQ(*dbc::decode(*m.find("F"), d), -3.25);
  EXPECT_DOUBLE_EQ(*dbc::decode(*m.find("D"), d), 1.0 + 2.0 * 3.141592653589793);
  EXPECT_TRUE(dbc::signal_active(m, *m.find("F"), d));
  EXPECT_FALSE(dbc::signal_active(m, *m.find("I"), d));
  EXPECT_TRUE(dbc::signal_active(m, *m.find("D"), d));
  ASSERT_EQ(dbc::encode(*m.find("Sel"), 2, d), dbc::EncodeStatus::kOk);
  EXPECT_FALSE(dbc::signal_active(m, *m.find("F"), d));
  EXPECT_TRUE(dbc::signal_active(m, *m.find("I"), d));
  EXPECT_EQ(dbc::format_value(*m.find("F"), -3.25), "-3.25");
  EXPECT_EQ(dbc::format_value(*m.find("I"), -0.0), "0.0");
  EXPECT_EQ(dbc::format_value(*m.find("Sel"), 7), "7");
}

}  // namespace
