// Issue 26 item 7: a rejected packet is counted once. The truth is the stream the synthetic sensor
// really sent, one packet of it damaged so that its decoder rejects it (a bad length, a corrupt
// block flag, every azimuth / measurement id out of range, a product or return-mode byte of
// another model); each sent packet must then be counted once in the scan it belongs to: in its
// packets (decoded), its `dropped` or its `missing_packets`, never two of them. Checked per scan
// against the clean run (no scan gained or lost a packet's count), for a model of each vendor.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "sensor_rig/lidar/mock/packet_fields.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "synthetic_stream.hpp"

namespace sensor_rig::lidar {
namespace {

using namespace test;  // the stream and its decode: synthetic_stream.hpp

// Index of the packet that starts a scan (the first after the cut), near `from`.
std::size_t scan_start_near(const Stream& s, std::size_t from) {
  for (std::size_t i = from; i + 1 < s.pkts.size(); ++i)
    if (s.pkts[i + 1].rotor_deg < s.pkts[i].rotor_deg) return i + 1;
  return from;
}

struct Damage {
  std::string name;
  std::function<void(std::vector<std::byte>&)> apply;
};

std::vector<Damage> damages(const Stream& s) {
  const mock::PacketFields fields(*s.sensor);
  std::vector<Damage> out;
  out.push_back({"truncated", [](std::vector<std::byte>& b) { b.resize(b.size() - 3); }});
  // Every azimuth field (Ouster: measurement id) read as 0xFFFF: past any turn or frame.
  const mock::FieldBytes az = fields.locate(mock::PacketField::kAzimuth);
  out.push_back({"azimuths_out_of_range", [fields, az](std::vector<std::byte>& b) {
                   std::vector<std::byte> frozen = b;
                   for (std::size_t k = 0; k < az.size; ++k) frozen[az.offset + k] = std::byte{0xFF};
                   fields.freeze_azimuth(b, frozen);
                 }});
  try {
    const mock::FieldBytes st = fields.locate(mock::PacketField::kColumnStatus);
    // Velodyne / Pandar40P: the first block's FF EE flag. Ouster: the first column's status (a
    // damaged column of a kept packet, not a rejection: its scan says so in `dropped`).
    if (!mock::is_ouster_model(s.options.model))
      out.push_back({"block_flag", [st](std::vector<std::byte>& b) {
                       for (std::size_t k = 0; k < st.size; ++k) b[st.offset + k] ^= std::byte{0x5A};
                     }});
  } catch (const std::invalid_argument&) {
  }
  return out;
}

class RejectedOnce : public ::testing::TestWithParam<const char*> {};

TEST_P(RejectedOnce, EachSentPacketIsDecodedDroppedOrMissingNeverTwo) {
  const Stream s = render(GetParam(), 0.6);
  const Decoded clean = run(s.options, s.pkts);
  ASSERT_GE(clean.scans.size(), 4U);
  const std::size_t start = scan_start_near(s, s.pkts.size() / 2);
  const auto half_scan = static_cast<std::size_t>(s.sensor->packets_per_second() / 20.0);
  for (const Damage& d : damages(s)) {
    // Mid-scan, and two in a row (the second's gap is the first's too).
    for (const std::size_t run_len : {std::size_t{1}, std::size_t{2}}) {
      auto pkts = s.pkts;
      const std::size_t at = start + half_scan;
      for (std::size_t i = at; i < at + run_len; ++i) d.apply(pkts[i].bytes);
      const Decoded r = run(s.options, pkts);
      SCOPED_TRACE(d.name + " x" + std::to_string(run_len));
      ASSERT_EQ(r.scans.size(), clean.scans.size());
      EXPECT_EQ(r.st.time_jumps, 0U);
      std::uint64_t dropped = 0, missing = 0;
      for (std::size_t k = 0; k < r.scans.size(); ++k) {
        const Scan& a = r.scans[k];
        const Scan& c = clean.scans[k];
        EXPECT_EQ(a.packets + a.dropped + a.missing_packets, c.packets + c.dropped + c.missing_packets)
            << "scan " << k << ": packets " << a.packets << " dropped " << a.dropped << " missing "
            << a.missing_packets << "; sent " << c.packets;
        dropped += a.dropped;
        missing += a.missing_packets;
      }
      EXPECT_EQ(dropped, run_len) << "the rejected packets, each a drop";
      EXPECT_EQ(missing, 0U) << "a rejected packet arrived: dropped, not missing too";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Models, RejectedOnce,
                         ::testing::Values("VLP-32C", "VLP-16", "Pandar40P", "PandarXT32", "OS-LEGACY"),
                         [](const auto& p) {
                           std::string n = p.param;
                           for (auto& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

}  // namespace
}  // namespace sensor_rig::lidar
