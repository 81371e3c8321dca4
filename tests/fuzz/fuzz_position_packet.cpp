// libFuzzer harness for Velodyne position packets and NMEA RMC sentences (no sockets).
// Input byte 0 bit 0: 0 = the rest is a position packet payload (any size), 1 = an NMEA sentence.
// Invariants: no crash; a parsed fix has in-range fields and hour_start <= utc < hour_start + 1 h,
// coordinates within ±90° / ±180° (what NavSatFix publishes), and a usable fix has coordinates.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string_view>

#include "sensor_rig/lidar/velodyne/position_packet.hpp"

namespace {

using namespace sensor_rig::lidar::velodyne;

void check(const RmcFix& f) {
  constexpr std::int64_t kHour = 3'600'000'000'000LL;
  if (f.month < 1 || f.month > 12 || f.day < 1 || f.day > 31 || f.hour > 23 || f.minute > 59) std::abort();
  if (f.utc_ns < f.hour_start_ns || f.utc_ns - f.hour_start_ns >= kHour + 2'000'000'000LL) std::abort();
  if (!(f.latitude_deg >= -90.0 && f.latitude_deg <= 90.0) || !(f.longitude_deg >= -180.0 && f.longitude_deg <= 180.0))
    std::abort();
  if (f.usable_fix() && (!f.valid || !f.has_position)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto* rest = data + 1;
  const std::size_t n = size - 1;
  if ((data[0] & 1) == 0) {
    PositionPacket p;
    if (parse_position_packet(std::as_bytes(std::span(rest, n)), p) == sensor_rig::lidar::PacketStatus::kOk &&
        p.nmea == NmeaStatus::kOk) {
      check(p.fix);
    }
  } else {
    RmcFix f;
    if (parse_rmc(std::string_view(reinterpret_cast<const char*>(rest), n), f) == NmeaStatus::kOk) check(f);
  }
  return 0;
}
