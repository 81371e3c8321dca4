// The truth record's units are the rig's scans: a fault-free synthetic stream of every model,
// decoded by the real decoder and scan assembly (make_decoder, stamped from the packets' own time
// as the driver's sensor time does), gives for every scan exactly the packets the truth unit says
// (parts) and the unit's first firing as its stamp (within the sensor clock's quantum).
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "sensor_rig/lidar/mock/sensor_faults.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

#include "../synthetic_sensor_factory.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr Nanos kStart = 1'700'000'123'456'789'123LL;  // 2023-11-14 22:15:23.456789123 UTC
constexpr Nanos kHourNs = 3'600'000'000'000LL;

struct Case {
  std::string model;
  double rpm;
  ReturnSelection returns;
  double rotor_deg;  // where the rotor starts: the first scan is partial
};

class TruthUnits : public testing::TestWithParam<Case> {};

TEST_P(TruthUnits, EveryDecodedScanIsATruthUnit) {
  const Case& c = GetParam();
  SyntheticOptions base;
  base.model = c.model;
  base.rpm = c.rpm;
  base.returns = c.returns;
  FaultySensor sensor(test::synthetic_sensor_factory(base), SensorSetup{kStart, c.rpm, c.rotor_deg, 0}, {});

  DecoderOptions d;
  d.model = c.model;
  d.returns = c.returns;
  if (is_ouster_model(c.model)) d.metadata_text = metadata_json(synthetic_ouster_metadata(base));
  auto dec = make_decoder(d);

  std::map<Nanos, ClosedUnit> units;  // by first firing
  std::vector<Scan> scans;
  const Nanos hour = kStart - kStart % kHourNs;  // the GPRMC hour a Velodyne's µs count from
  while (true) {
    const FaultyPacket fp = sensor.next();
    for (const ClosedUnit& u : sensor.units().closed()) units.emplace(u.acq_ns, u);
    sensor.units().closed().clear();
    if (fp.packet.time_ns - kStart > 1'050'000'000) break;
    if (!fp.packet.truth.data) continue;
    const PacketView view{fp.packet.bytes, fp.packet.time_ns, 0};
    ASSERT_TRUE(dec->is_data_packet(view));
    const SensorTime t = dec->packet_time(fp.packet.bytes);
    const Nanos stamp = t.kind == SensorTime::Kind::kMicrosSinceHour ? hour + t.value * 1000 : t.value;
    if (auto s = dec->push(view, stamp)) scans.push_back(std::move(*s));
  }
  // ~10 scans in 1 s; a first scan started mid-turn is not emitted, the one in progress is not either.
  ASSERT_GE(scans.size(), c.rpm == 1200.0 ? 18u : 8u);
  ASSERT_GE(units.size(), scans.size());
  const Nanos quantum = is_ouster_model(c.model) ? 1 : 1000;  // Velodyne, Hesai: µs on the wire
  for (const Scan& s : scans) {
    auto it = units.lower_bound(s.stamp - quantum);
    ASSERT_NE(it, units.end()) << "scan " << s.seq << " stamped " << s.stamp;
    EXPECT_LE(std::abs(it->second.acq_ns - s.stamp), quantum) << c.model << " scan " << s.seq;
    EXPECT_EQ(s.packets, it->second.parts) << c.model << " scan " << s.seq << " unit " << it->second.unit;
    EXPECT_EQ(s.missing_packets, 0u);
  }
  // And the truth has no unit the decoder did not publish between its first and last scan.
  const auto first = units.lower_bound(scans.front().stamp - quantum);
  const auto last = units.upper_bound(scans.back().stamp + quantum);
  EXPECT_EQ(static_cast<std::size_t>(std::distance(first, last)), scans.size());
}

INSTANTIATE_TEST_SUITE_P(
    Models, TruthUnits,
    testing::Values(Case{"VLP-16", 600, ReturnSelection::kStrongest, 37.0}, Case{"VLP-32C", 600, ReturnSelection::kStrongest, 200.0},
                    Case{"VLP-32C", 1200, ReturnSelection::kDual, 359.9}, Case{"HDL-32E", 600, ReturnSelection::kLast, 10.0},
                    Case{"OS-LEGACY", 600, ReturnSelection::kStrongest, 90.0}, Case{"OS", 1200, ReturnSelection::kStrongest, 0.0},
                    Case{"Pandar40P", 600, ReturnSelection::kStrongest, 123.4}, Case{"Pandar40P", 1200, ReturnSelection::kDual, 350.0},
                    Case{"PandarXT32", 600, ReturnSelection::kStrongest, 5.0}),
    [](const testing::TestParamInfo<Case>& i) {
      std::string n = i.param.model + "_" + std::to_string(static_cast<int>(i.param.rpm)) + "_" + std::to_string(i.index);
      for (char& ch : n)
        if (ch == '-') ch = '_';
      return n;
    });

}  // namespace
}  // namespace sensor_rig::lidar::mock
