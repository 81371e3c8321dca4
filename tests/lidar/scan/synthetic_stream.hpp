#pragma once
// The LIDAR scan tests' stream: a synthetic sensor's genuine data packets (as the driver would
// receive them, stamped with their first firing), and the scans and counters a decoder of the
// registry makes of them, each packet received 0.1 ms after the sensor sent it.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/packet_fields.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::lidar::test {

struct Pkt {
  std::vector<std::byte> bytes;
  Nanos stamp = 0;  // first firing (what the driver's stamper gives)
  double rotor_deg = 0.0;
  Nanos sent_ns = 0;  // when the sensor sent it (its truth; a test's changes to stamp or bytes leave it)
};

struct Stream {
  std::vector<Pkt> pkts;
  DecoderOptions options;
  mock::FieldBytes time_field;
  std::unique_ptr<mock::SyntheticSensor> sensor;  // for freeze_azimuth's layout
};

// `clock_ns`: the sensor's clock that far ahead (the same packets, their times moved).
inline Stream render(const std::string& model, double seconds, Nanos clock_ns = 0) {
  mock::SyntheticOptions o;
  o.model = model;
  o.ouster_imu_period_ns = 0;
  o.start_ns = 1'700'000'000'000'000'000LL + clock_ns;
  Stream s;
  s.sensor = mock::make_synthetic_sensor(o, mock::Scene::standard());
  s.options.model = model;
  if (mock::is_ouster_model(model)) {
    s.options.metadata_text = mock::metadata_json(mock::synthetic_ouster_metadata(o));
    s.options.metadata_name = "synthetic";
  }
  s.time_field = mock::PacketFields(*s.sensor).locate(mock::PacketField::kTime);
  const auto n = static_cast<std::size_t>(s.sensor->packets_per_second() * seconds);
  while (s.pkts.size() < n) {
    const mock::SyntheticPacket p = s.sensor->next();
    if (!p.truth.data) continue;
    s.pkts.push_back({std::vector<std::byte>(p.bytes.begin(), p.bytes.end()), p.truth.acq_ns, p.truth.rotor_deg, p.truth.acq_ns});
  }
  return s;
}

struct Decoded {
  std::vector<Scan> scans;
  DecoderCounters st;
  [[nodiscard]] std::uint64_t missing() const {
    std::uint64_t m = 0;
    for (const auto& s : scans) m += s.missing_packets;
    return m;
  }
  [[nodiscard]] std::uint64_t dropped() const {
    std::uint64_t m = 0;
    for (const auto& s : scans) m += s.dropped;
    return m;
  }
  [[nodiscard]] std::uint64_t points() const {
    std::uint64_t m = 0;
    for (const auto& s : scans) m += s.points.size();
    return m;
  }
};

// The host's CLOCK_REALTIME stepped by `by` from packet `at` on: their kernel receive stamps move,
// their CLOCK_MONOTONIC receive times do not (PacketView::rx_mono_ns).
struct HostStep {
  std::size_t at = 0;
  Nanos by = 0;
};

inline Decoded run(const DecoderOptions& o, const std::vector<Pkt>& pkts, HostStep host = {}) {
  const auto dec = make_decoder(o);
  Decoded r;
  // Received 100 us after it was sent, in order (a packet moved later in the list arrives just after
  // the one before it): the receive times bound the turns a gap in the sensor's time can hide
  // (lidar/stream_gap.hpp sensor_step_within_receive), so they run at the sensor's pace, as a real stream's
  // do. Packets without a send time (sent_ns 0), 0.1 ms after the last.
  Nanos rx = 1'000'000'000;
  for (std::size_t i = 0; i < pkts.size(); ++i) {
    const Pkt& p = pkts[i];
    rx = p.sent_ns > 0 ? std::max(rx + 1, p.sent_ns + 100'000) : rx + 100'000;
    const Nanos real = rx + (host.by != 0 && i >= host.at ? host.by : 0);
    if (auto s = dec->push(PacketView{p.bytes, real, 0, rx}, p.stamp)) r.scans.push_back(std::move(*s));
  }
  r.st = dec->counters();
  return r;
}

}  // namespace sensor_rig::lidar::test
