// Hesai model tables, packet checks and packet time.
#include "sensor_rig/lidar/hesai/model.hpp"

#include <algorithm>
#include <array>

#include "sensor_rig/lidar/hesai/packet.hpp"

namespace sensor_rig::lidar::hesai {
namespace {

// Firing time of each channel (µs) within its azimuth group, indexed by channel - 1: the vendor's
// Firetime tables (HesaiLidar_SDK_2.0 Pandar40P_Firetime.csv / PandarXT-32_Firetime.csv, the user
// manuals' values) turned into code; tests/lidar/hesai checks them against the CSV files.
// ModelInfo::group_period_ns / tail_to_last_group_ns place the groups relative to the tail time.
constexpr std::array<double, 40> kFire40P{
    -42.22, -28.47, -16.04, -3.62,  -45.49, -31.74, -47.46, -54.67, -20.62, -33.71,
    -40.91, -8.19,  -20.62, -27.16, -50.73, -8.19,  -14.74, -36.98, -45.49, -52.70,
    -23.89, -31.74, -38.95, -11.47, -18.65, -25.19, -48.76, -6.23,  -12.77, -35.01,
    -21.92, -9.50,  -43.52, -29.77, -17.35, -4.92,  -42.22, -28.47, -16.04, -3.62};
constexpr std::array<double, 32> kFireXT32 = [] {
  std::array<double, 32> a{};
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = 6.0 + 1.512 * static_cast<double>(i);
  return a;
}();

const ModelInfo kModels[] = {
    {"Pandar40P", 40, 10, k40PPacketSize, k40PPacketSizeWithSequence, 0, sizeof(Block40P),
     offsetof(Block40P, azimuth), offsetof(Block40P, units), sizeof(Unit3),
     offsetof(Packet40P, tail) + offsetof(Tail40P, return_mode), offsetof(Packet40P, tail) + offsetof(Tail40P, utc),
     offsetof(Packet40P, tail) + offsetof(Tail40P, timestamp), 2000, 0.004, 55'560, -28'580, kFire40P, 72'000},
    {"PandarXT32", 32, 8, kXT32PacketSize, 0, offsetof(PacketXT32, blocks), sizeof(BlockXT32),
     offsetof(BlockXT32, azimuth), offsetof(BlockXT32, units), sizeof(Unit4),
     offsetof(PacketXT32, tail) + offsetof(TailXT32, return_mode),
     offsetof(PacketXT32, tail) + offsetof(TailXT32, utc), offsetof(PacketXT32, tail) + offsetof(TailXT32, timestamp),
     1900, 0.004, 50'000, 0, kFireXT32, 64'000},
};

constexpr std::uint8_t kSob0 = 0xFF, kSob1 = 0xEE;  // Pandar40P start of block
constexpr std::uint8_t kSop0 = 0xEE, kSop1 = 0xFF;  // XT start of packet

// Days from 1970-01-01 to y-m-d (proleptic Gregorian), no time zone or libc involved.
constexpr std::int64_t days_from_civil(std::int64_t y, unsigned m, unsigned d) noexcept {
  y -= m <= 2 ? 1 : 0;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}
static_assert(days_from_civil(1970, 1, 1) == 0);
static_assert(days_from_civil(2000, 3, 1) == 11017);

}  // namespace

const ModelInfo& model_info(Model m) noexcept { return kModels[static_cast<std::size_t>(m)]; }

std::optional<Model> model_from_name(std::string_view name) noexcept {
  for (const auto m : {Model::kPandar40P, Model::kPandarXT32})
    if (model_info(m).name == name) return m;
  return std::nullopt;
}

std::optional<std::int64_t> utc_seconds(std::span<const std::uint8_t, 6> utc, int year_offset) noexcept {
  const unsigned mon = utc[1], day = utc[2], h = utc[3], mi = utc[4], s = utc[5];
  if (mon < 1 || mon > 12 || day < 1 || day > 31 || h > 23 || mi > 59 || s > 60) return std::nullopt;
  const std::int64_t days = days_from_civil(year_offset + utc[0], mon, day);
  return days * 86400 + h * 3600 + mi * 60 + s;
}

PacketStatus check_packet(std::span<const std::byte> bytes, Model m) noexcept {
  const ModelInfo& mi = model_info(m);
  if (bytes.size() != mi.packet_size && (mi.packet_size_alt == 0 || bytes.size() != mi.packet_size_alt)) {
    return bytes.size() == kGpsPacketSize ? PacketStatus::kNotData : PacketStatus::kWrongSize;
  }
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  if (m == Model::kPandarXT32) {
    if (p[0] != kSop0 || p[1] != kSop1) return PacketStatus::kBadBlockFlag;
    if (p[offsetof(HeaderXT, laser_num)] != mi.channels || p[offsetof(HeaderXT, block_num)] != mi.blocks ||
        p[offsetof(HeaderXT, dis_unit)] == 0) {
      return PacketStatus::kWrongModel;
    }
  }
  for (int b = 0; b < mi.blocks; ++b) {
    const std::uint8_t* blk = p + mi.first_block + static_cast<std::size_t>(b) * mi.block_size;
    if (m == Model::kPandar40P && (blk[0] != kSob0 || blk[1] != kSob1)) return PacketStatus::kBadBlockFlag;
    if (le16(blk + mi.block_azimuth) >= kAzimuthCount) return PacketStatus::kBadAzimuth;
  }
  const int n = return_count(p[mi.tail_return_mode]);
  return n == 1 || n == 2 ? PacketStatus::kOk : PacketStatus::kWrongModel;
}

Nanos first_firing_offset_ns(Model m, int returns) noexcept {
  const ModelInfo& mi = model_info(m);
  const int groups = mi.blocks / std::max(returns, 1);
  const double min_fire = *std::min_element(mi.firing_us.begin(), mi.firing_us.end());
  return static_cast<Nanos>(mi.tail_to_last_group_ns) - static_cast<Nanos>(mi.group_period_ns) * (groups - 1) +
         static_cast<Nanos>(min_fire * 1000.0 + (min_fire < 0 ? -0.5 : 0.5));
}

std::optional<PacketInfo> read_packet_info(std::span<const std::byte> bytes, Model m) noexcept {
  if (check_packet(bytes, m) != PacketStatus::kOk) return std::nullopt;
  const ModelInfo& mi = model_info(m);
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  PacketInfo info;
  info.return_mode = p[mi.tail_return_mode];
  info.returns = return_count(info.return_mode);
  const std::uint32_t us = le32(p + mi.tail_timestamp);
  const auto sec = utc_seconds(std::span<const std::uint8_t, 6>(p + mi.tail_utc, 6), mi.year_offset);
  if (sec && us < 1'000'000U) info.tail_time_ns = *sec * 1'000'000'000LL + static_cast<Nanos>(us) * 1000;
  return info;
}

}  // namespace sensor_rig::lidar::hesai
