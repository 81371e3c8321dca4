// Velodyne position packets: layout, RMC parsing (real sentences, bad checksums, truncation), encoding.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/velodyne/position_packet.hpp"

namespace sensor_rig::lidar::velodyne {
namespace {

// From the HDL-32E capture VeloView ships (Monterey, 2012-12-11 22:06:32 UTC).
constexpr std::string_view kHdl32Sentence =
    "$GPRMC,220632,A,3707.8324,N,12139.2864,W,000.0,144.7,111212,013.8,E,D*09\r\n";

std::array<std::byte, kPositionPacketSize> packet_with(std::uint32_t us, PpsState pps, std::string_view s) {
  std::array<std::byte, kPositionPacketSize> buf{};
  encode_position_packet(us, pps, s, buf);
  return buf;
}

TEST(Rmc, ParsesRealHdl32Sentence) {
  RmcFix fix;
  ASSERT_EQ(parse_rmc(kHdl32Sentence, fix), NmeaStatus::kOk);
  EXPECT_TRUE(fix.valid);
  EXPECT_EQ(fix.year, 2012);
  EXPECT_EQ(fix.month, 12);
  EXPECT_EQ(fix.day, 11);
  EXPECT_EQ(fix.hour, 22);
  EXPECT_EQ(fix.minute, 6);
  EXPECT_DOUBLE_EQ(fix.second, 32.0);
  // date -u -d '2012-12-11 22:06:32' +%s == 1355263592
  EXPECT_EQ(fix.utc_ns, 1355263592LL * kSec);
  EXPECT_EQ(fix.hour_start_ns, (1355263592LL - 6 * 60 - 32) * kSec);
  EXPECT_NEAR(fix.latitude_deg, 37.0 + 7.8324 / 60.0, 1e-9);
  EXPECT_NEAR(fix.longitude_deg, -(121.0 + 39.2864 / 60.0), 1e-9);
}

TEST(Rmc, FractionalSecondsAndOtherTalkers) {
  // u-blox style with fractional seconds, GN talker and a void fix.
  std::string body = "GNRMC,235959.250,V,,,,,,,311299,,,N";
  std::string s = "$" + body + "*";
  char hex[3];
  std::snprintf(hex, sizeof hex, "%02X", nmea_checksum(s));
  s += hex;
  RmcFix fix;
  ASSERT_EQ(parse_rmc(s, fix), NmeaStatus::kOk);
  EXPECT_FALSE(fix.valid);
  EXPECT_EQ(fix.year, 1999);
  EXPECT_DOUBLE_EQ(fix.second, 59.25);
  // 1999-12-31 23:59:59.25 UTC = 946684799.25
  EXPECT_EQ(fix.utc_ns, 946684799LL * kSec + 250'000'000LL);
  EXPECT_EQ(fix.hour_start_ns, (946684799LL - 59 * 60 - 59) * kSec);
}

TEST(Rmc, RejectsBadChecksum) {
  std::string s(kHdl32Sentence);
  s[s.find("*09")] = '*';
  s.replace(s.find("*09") + 1, 2, "0A");
  RmcFix fix;
  EXPECT_EQ(parse_rmc(s, fix), NmeaStatus::kBadChecksum);
  std::string flipped(kHdl32Sentence);
  flipped[10] = '7';  // a digit of the time changed in transit
  EXPECT_EQ(parse_rmc(flipped, fix), NmeaStatus::kBadChecksum);
}

TEST(Rmc, RejectsTruncatedAndMalformed) {
  RmcFix fix;
  EXPECT_EQ(parse_rmc(kHdl32Sentence.substr(0, 40), fix), NmeaStatus::kTruncated);
  EXPECT_EQ(parse_rmc(kHdl32Sentence.substr(0, kHdl32Sentence.find('*') + 2), fix), NmeaStatus::kTruncated);
  EXPECT_EQ(parse_rmc("", fix), NmeaStatus::kMissing);
  EXPECT_EQ(parse_rmc("GPRMC,220632,A*00", fix), NmeaStatus::kMalformed);  // no '$'
  EXPECT_EQ(parse_rmc("$GPGGA,220632,3707.8324,N,12139.2864,W,1,08,0.9,545.4,M,46.9,M,,*4B", fix),
            NmeaStatus::kBadChecksum);
  // Correct checksums, wrong content.
  auto with_sum = [](const std::string& body) {
    std::string s = "$" + body + "*";
    char hex[3];
    std::snprintf(hex, sizeof hex, "%02X", nmea_checksum(s));
    return s + hex;
  };
  EXPECT_EQ(parse_rmc(with_sum("GPGGA,220632,3707.8324,N,12139.2864,W,1,08,0.9,545.4,M,46.9,M,,"), fix),
            NmeaStatus::kNotRmc);
  EXPECT_EQ(parse_rmc(with_sum("GPRMC,250632,A,3707.8324,N,12139.2864,W,000.0,144.7,111212,,"), fix),
            NmeaStatus::kMalformed);  // hour 25
  EXPECT_EQ(parse_rmc(with_sum("GPRMC,220632,A,3707.8324,N,12139.2864,W,000.0,144.7,111312,,"), fix),
            NmeaStatus::kMalformed);  // month 13
  EXPECT_EQ(parse_rmc(with_sum("GPRMC,220632,X,3707.8324,N,12139.2864,W,000.0,144.7,111212,,"), fix),
            NmeaStatus::kMalformed);  // status neither A nor V
  EXPECT_EQ(parse_rmc(with_sum("GPRMC,220632,A,3707.8324,N"), fix), NmeaStatus::kMalformed);  // fields missing
  EXPECT_EQ(parse_rmc(with_sum("GPRMC,2206,A,3707.8324,N,12139.2864,W,000.0,144.7,111212,,"), fix),
            NmeaStatus::kMalformed);  // short time
}

TEST(PositionPacket, LayoutOffsetsMatchManual) {
  const auto buf = packet_with(0x01020304u, PpsState::kLocked, kHdl32Sentence);
  EXPECT_EQ(std::to_integer<int>(buf[198]), 0x04);
  EXPECT_EQ(std::to_integer<int>(buf[201]), 0x01);
  EXPECT_EQ(std::to_integer<int>(buf[202]), 2);
  EXPECT_EQ(std::to_integer<char>(buf[206]), '$');
  EXPECT_EQ(std::to_integer<int>(buf[206 + kHdl32Sentence.size()]), 0);
}

TEST(PositionPacket, ParsesEncodedPacket) {
  const auto buf = packet_with(2'192'000'000u, PpsState::kLocked, kHdl32Sentence);
  PositionPacket p;
  ASSERT_EQ(parse_position_packet(buf, p), PacketStatus::kOk);
  EXPECT_EQ(p.sensor_time_us, 2'192'000'000u);
  EXPECT_EQ(p.pps, PpsState::kLocked);
  ASSERT_EQ(p.nmea, NmeaStatus::kOk);
  EXPECT_EQ(p.fix.minute, 6);
  // Sensor time = GPRMC hour + µs since hour.
  EXPECT_EQ(p.fix.hour_start_ns + static_cast<Nanos>(p.sensor_time_us) * 1000, p.fix.hour_start_ns + 2192 * kSec);
}

TEST(PositionPacket, BadInputIsAStatusNotACrash) {
  PositionPacket p;
  std::array<std::byte, kPositionPacketSize + 1> big{};
  EXPECT_EQ(parse_position_packet(std::span<const std::byte>(big).first(100), p), PacketStatus::kWrongSize);
  EXPECT_EQ(parse_position_packet(big, p), PacketStatus::kWrongSize);

  auto empty = packet_with(5, PpsState::kAbsent, "");
  ASSERT_EQ(parse_position_packet(empty, p), PacketStatus::kOk);
  EXPECT_EQ(p.nmea, NmeaStatus::kMissing);
  EXPECT_EQ(p.pps, PpsState::kAbsent);

  // A sentence filling the whole field with no terminator and no checksum.
  std::array<std::byte, kPositionPacketSize> full{};
  encode_position_packet(5, PpsState::kSynchronizing, std::string(200, 'A'), full);
  full[206] = std::byte{'$'};
  ASSERT_EQ(parse_position_packet(full, p), PacketStatus::kOk);
  EXPECT_EQ(p.nmea, NmeaStatus::kTruncated);
  EXPECT_EQ(p.pps, PpsState::kSynchronizing);

  full[202] = std::byte{0x7F};  // undefined PPS value
  ASSERT_EQ(parse_position_packet(full, p), PacketStatus::kOk);
  EXPECT_EQ(p.pps, PpsState::kError);
}

TEST(PositionPacket, FormatRoundTrips) {
  // 2024-02-29 13:45:07.9 UTC: leap day, sub-second part dropped by the hhmmss form.
  const Nanos t = 1709214307LL * kSec + 900'000'000LL;
  const std::string s = format_rmc({t, true, -33.8568, 151.2153});
  RmcFix fix;
  ASSERT_EQ(parse_rmc(s, fix), NmeaStatus::kOk) << s;
  EXPECT_EQ(fix.utc_ns, 1709214307LL * kSec);
  EXPECT_EQ(fix.year, 2024);
  EXPECT_EQ(fix.month, 2);
  EXPECT_EQ(fix.day, 29);
  EXPECT_NEAR(fix.latitude_deg, -33.8568, 1e-4);
  EXPECT_NEAR(fix.longitude_deg, 151.2153, 1e-4);
  EXPECT_EQ(s.substr(s.size() - 2), "\r\n");

  const std::string v = format_rmc({t, false, 0.0, 0.0});
  ASSERT_EQ(parse_rmc(v, fix), NmeaStatus::kOk) << v;
  EXPECT_FALSE(fix.valid);
}

// What the NavSatFix of the LIDAR node is built from: coordinates present, status, mode indicator.
std::string with_checksum(std::string_view body) {
  char tail[8];
  std::snprintf(tail, sizeof tail, "*%02X", nmea_checksum(body));
  return "$" + std::string(body) + tail;
}

TEST(Rmc, FixUsabilityFromStatusFieldsAndMode) {
  RmcFix fix;
  ASSERT_EQ(parse_rmc(kHdl32Sentence, fix), NmeaStatus::kOk);
  EXPECT_TRUE(fix.has_position);
  EXPECT_EQ(fix.mode, 'D');
  EXPECT_TRUE(fix.usable_fix());
  // Void fix: parsed (its time is still good for the clock), not a usable position.
  ASSERT_EQ(parse_rmc(with_checksum("GPRMC,220632,V,3707.8324,N,12139.2864,W,,,111212,,"), fix), NmeaStatus::kOk);
  EXPECT_FALSE(fix.valid);
  EXPECT_TRUE(fix.has_position);
  EXPECT_EQ(fix.mode, '\0');
  EXPECT_FALSE(fix.usable_fix());
  // Status A but empty coordinates (a receiver before its first fix) or a missing hemisphere.
  ASSERT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,,,,,,,111212,,,A"), fix), NmeaStatus::kOk);
  EXPECT_FALSE(fix.has_position);
  EXPECT_FALSE(fix.usable_fix());
  ASSERT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,3707.8324,,12139.2864,W,,,111212,,,A"), fix), NmeaStatus::kOk);
  EXPECT_FALSE(fix.has_position);
  // NMEA 2.3 mode N = data not valid.
  ASSERT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,3707.8324,N,12139.2864,W,,,111212,,,N"), fix), NmeaStatus::kOk);
  EXPECT_TRUE(fix.has_position);
  EXPECT_FALSE(fix.usable_fix());
  // Southern / eastern hemispheres.
  ASSERT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,3352.1200,S,15112.6000,E,,,111212,,,A"), fix), NmeaStatus::kOk);
  EXPECT_NEAR(fix.latitude_deg, -(33.0 + 52.12 / 60.0), 1e-9);
  EXPECT_NEAR(fix.longitude_deg, 151.0 + 12.6 / 60.0, 1e-9);
  EXPECT_TRUE(fix.usable_fix());
}

TEST(Rmc, CoordinatesOutOfRangeAreMalformed) {
  RmcFix fix;
  EXPECT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,9100.0000,N,12139.2864,W,,,111212,,,A"), fix), NmeaStatus::kMalformed);
  EXPECT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,3707.8324,N,18100.0000,W,,,111212,,,A"), fix), NmeaStatus::kMalformed);
  EXPECT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,3707.8324,N,12160.0000,W,,,111212,,,A"), fix), NmeaStatus::kMalformed);
  EXPECT_EQ(parse_rmc(with_checksum("GPRMC,220632,A,-3707.8324,N,12139.2864,W,,,111212,,,A"), fix), NmeaStatus::kMalformed);
  // Every single-bit flip of the real sentence's body is caught by the checksum or the parser.
  const std::string real(kHdl32Sentence.substr(0, kHdl32Sentence.find('*')));
  for (std::size_t i = 1; i < real.size(); ++i) {
    for (int bit = 0; bit < 7; ++bit) {
      std::string s(kHdl32Sentence);
      s[i] = static_cast<char>(s[i] ^ (1 << bit));
      RmcFix f;
      EXPECT_NE(parse_rmc(s, f), NmeaStatus::kOk) << s;
    }
  }
}

}  // namespace
}  // namespace sensor_rig::lidar::velodyne
