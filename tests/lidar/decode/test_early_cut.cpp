// A scan is emitted with the packet that holds its last block, not one packet later: the decoder
// predicts from the azimuth step that the next block crosses the cut. Checked on synthetic streams
// of every model and several cut angles, against the packet azimuths themselves.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar {
namespace {
namespace vel = velodyne;

int last_azimuth(const std::array<std::byte, vel::kDataPacketSize>& p) {
  const auto* b = reinterpret_cast<const std::uint8_t*>(p.data());
  const std::size_t last = vel::kBlocksPerPacket - 1;
  return vel::le16(b + last * sizeof(vel::RawBlock) + 2);
}

struct Case {
  vel::Model model;
  double cut_deg;
};

class EarlyCut : public ::testing::TestWithParam<Case> {};

TEST_P(EarlyCut, ScanEndsWithThePacketHoldingItsLastBlock) {
  const auto c = GetParam();
  mock::SyntheticConfig sc;
  sc.model = c.model;
  sc.start_ns = 1'700'000'000'000'000'000;
  sc.start_azimuth_deg = 37.0;
  mock::SyntheticVelodyne sensor(sc, mock::Scene::standard());
  vel::DecoderConfig dc;
  dc.model = c.model;
  dc.cut_angle_deg = c.cut_deg;
  vel::Decoder dec(dc);
  const int cut = static_cast<int>(std::lround(c.cut_deg * 100.0));

  std::array<std::byte, vel::kDataPacketSize> pkt{};
  int scans = 0;
  int predicted = 0;
  const auto packets = static_cast<std::uint64_t>(sensor.packets_per_second() * 4.0);  // ~40 scans
  for (std::uint64_t i = 0; i < packets; ++i) {
    sensor.render_data_packet(i, pkt);
    const auto scan = dec.push(PacketView{pkt, sensor.data_packet_time(i), 2368}, sensor.data_packet_time(i));
    const int last_az = last_azimuth(pkt);
    // Where the first block of the *next* packet will be: one block step past this packet's last.
    const auto* b = reinterpret_cast<const std::uint8_t*>(pkt.data());
    const int step = (last_az - vel::le16(b + (vel::kBlocksPerPacket - 2) * sizeof(vel::RawBlock) + 2) + 36000) % 36000;
    const int to_cut = (cut - last_az + 36000) % 36000;
    // The next packet's first block crosses the cut clearly (beyond the decoder's 2/100° margin):
    // the scan must come out with this packet, not one packet interval later.
    const bool next_crosses = to_cut > 0 && to_cut + 2 <= step;
    if (next_crosses) {
      ++predicted;
      EXPECT_TRUE(scan.has_value()) << "packet " << i << " last azimuth " << last_az << " step " << step;
      if (scan) {
        EXPECT_EQ(scan->last_rx_ns, sensor.data_packet_time(i)) << "the scan's last packet is this one";
      }
    }
    if (scan) {
      ++scans;
      EXPECT_GT(scan->points.size(), 1000u);
    }
  }
  EXPECT_GE(scans, 35);
  EXPECT_GE(predicted, 1) << "about one scan in twelve ends at a packet boundary";
  EXPECT_EQ(dec.stats().early_cut_misses, 0u);
  EXPECT_EQ(dec.stats().dropped(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Models, EarlyCut,
                         ::testing::Values(Case{vel::Model::kVLP16, 0.0}, Case{vel::Model::kVLP16, 90.0},
                                           Case{vel::Model::kVLP32C, 0.0}, Case{vel::Model::kHDL32E, 0.0},
                                           Case{vel::Model::kHDL32E, 181.3}));

}  // namespace
}  // namespace sensor_rig::lidar
