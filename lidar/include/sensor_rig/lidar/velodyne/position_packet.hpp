#pragma once
// Velodyne position (telemetry / GPS) packet, UDP port 8308, 512-byte payload. Layout from the
// VLP-16, VLP-32C and HDL-32E user manuals: the sensor's µs-since-hour at 198, the PPS status at
// 202 (VLP-16/32C; 0 on the HDL-32E) and the last NMEA $GPRMC sentence received from the GPS at
// 206, NUL padded. The HDL-32E also puts gyro/temperature/acceleration words at 14..37 (not used).
// Pure parsing and encoding: no I/O, no clock reads. Parsing returns statuses, never throws.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "sensor_rig/common/pps_state.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::velodyne {

inline constexpr std::size_t kNmeaFieldSize = 128;

struct RawPositionPacket {
  std::uint8_t reserved0[14];
  std::uint8_t imu[24];          // HDL-32E gyro / temperature / accelerometer words
  std::uint8_t reserved1[160];
  std::uint8_t timestamp[4];     // little-endian µs since the top of the hour
  std::uint8_t pps_status;       // PpsState (0..3)
  std::uint8_t reserved2[3];
  char nmea[kNmeaFieldSize];     // "$GPRMC,...*hh\r\n", NUL padded
  std::uint8_t reserved3[178];
};
static_assert(sizeof(RawPositionPacket) == kPositionPacketSize);
static_assert(offsetof(RawPositionPacket, timestamp) == 198);
static_assert(offsetof(RawPositionPacket, pps_status) == 202);
static_assert(offsetof(RawPositionPacket, nmea) == 206);

using sensor_rig::PpsState;  // the position packet's PPS byte (0..3); common/pps_state.hpp

enum class NmeaStatus : std::uint8_t {
  kOk = 0,
  kMissing,      // no sentence in the packet (no GPS connected)
  kTruncated,    // no "*hh" checksum or the sentence runs off the field
  kBadChecksum,  // XOR of the characters between '$' and '*' differs from hh
  kNotRmc,       // another sentence type (e.g. $GPGGA)
  kMalformed,    // RMC with missing or out-of-range time/date fields
};
const char* to_string(NmeaStatus s) noexcept;

// A parsed $--RMC sentence (talker GP, GN, ...).
struct RmcFix {
  bool valid = false;           // status field: A = valid fix, V = receiver warning
  int year = 0, month = 0, day = 0;
  int hour = 0, minute = 0;
  double second = 0.0;          // including the fraction the sentence carries
  Nanos utc_ns = 0;             // the sentence's time as ns since the Unix epoch (UTC)
  Nanos hour_start_ns = 0;      // top of that hour: add the sensor's µs-since-hour to this
  double latitude_deg = 0.0;    // + north (0 when the field is empty)
  double longitude_deg = 0.0;   // + east
  bool has_position = false;    // latitude and longitude fields (and their N/S, E/W) all present
  char mode = '\0';             // NMEA 2.3 mode indicator (A autonomous, D differential, E, M, S, N not valid); 0 = absent
  // A position fix a consumer may use: status A, both coordinates present, mode not 'N'.
  [[nodiscard]] bool usable_fix() const noexcept { return valid && has_position && mode != 'N'; }
};

// Parses one sentence ("$GPRMC,...*hh", trailing CR/LF/NUL ignored). Checksum is verified.
NmeaStatus parse_rmc(std::string_view sentence, RmcFix& out) noexcept;

struct PositionPacket {
  std::uint32_t sensor_time_us = 0;  // µs since the top of the hour
  PpsState pps = PpsState::kAbsent;
  NmeaStatus nmea = NmeaStatus::kMissing;
  RmcFix fix;                        // meaningful when nmea == kOk
};

// kOk, or kWrongSize for anything but 512 bytes. A PPS byte above 3 reads as PpsState::kError.
// A bad or missing sentence still yields kOk with `nmea` saying what was wrong.
PacketStatus parse_position_packet(std::span<const std::byte> bytes, PositionPacket& out) noexcept;

// ---- encoding (mock sensors, tests) ----

struct RmcInput {
  Nanos utc_ns = 0;  // fix time; written as hhmmss (whole seconds) like Velodyne's GPS examples
  bool valid = true;
  double latitude_deg = 48.7758;   // + north
  double longitude_deg = 9.1829;   // + east
};
// "$GPRMC,hhmmss,A,ddmm.mmmm,N,dddmm.mmmm,E,000.0,000.0,ddmmyy,,,A*hh\r\n"
std::string format_rmc(const RmcInput& in);

// Fills a 512-byte position packet. The sentence is cut to the field (callers keep it short).
void encode_position_packet(std::uint32_t sensor_time_us, PpsState pps, std::string_view sentence,
                            std::span<std::byte, kPositionPacketSize> out) noexcept;

// XOR of the characters between '$' and '*' (or the end).
std::uint8_t nmea_checksum(std::string_view body) noexcept;

}  // namespace sensor_rig::lidar::velodyne
