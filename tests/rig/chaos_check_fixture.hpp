#pragma once
// The judge tests' planted truth: one LIDAR (50 scans of 10 packets, 100 ms apart) and what an
// honest rig publishes for it; each test plants one lie.
#include <cstdint>
#include <string>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

inline constexpr Nanos kT0 = 1'800'000'000'000'000'000;
inline constexpr Nanos kPeriod = 100'000'000;
inline constexpr int kScans = 50;
inline constexpr std::uint32_t kParts = 10;
inline const std::string kTopic = "/sensors/lidar/front/points";

inline truth::Log lidar_truth() {
  truth::Log log;
  log.header = truth::Header{"front", "lidar", "VLP-32C", kTopic, "scan", "sensor"};
  std::uint64_t seq = 0;
  for (int u = 0; u < kScans; ++u) {
    const Nanos acq = kT0 + u * kPeriod;
    log.units.push_back(truth::UnitRecord{u, acq, acq, kParts});
    for (std::uint32_t p = 0; p < kParts; ++p)
      log.parts.push_back(truth::PartRecord{seq++, u, acq + p * (kPeriod / kParts), 0, acq + p * (kPeriod / kParts), truth::Fate::kSent, 0});
  }
  return log;
}

// What an honest rig publishes for that truth: every scan, stamped at its first firing, all received.
inline Input honest() {
  Input in;
  in.truths.push_back(lidar_truth());
  for (int u = 0; u < kScans; ++u) {
    SampleRecord s;
    s.topic = kTopic;
    s.seq = static_cast<std::uint64_t>(u);
    s.acquisition_ns = kT0 + u * kPeriod;
    s.publish_ns = s.acquisition_ns + kPeriod + 5'000'000;
    s.received_ns = s.publish_ns + 1'000'000;
    s.packets = kParts;
    in.samples.push_back(s);
  }
  in.monitor[kTopic] = MonitorTotals{kScans, 0};
  in.expected[kTopic] = TopicExpectation{"front", 10.0, {}};
  in.epoch_vehicle_ns = kT0;
  in.window_begin_ns = kT0;
  in.window_end_ns = kT0 + kScans * kPeriod;
  return in;
}

// A CAN topic's sample of frame `frame` (one sample a frame, its seq the frame's): acquired at
// `acquisition_ns`, published `publish_after_ns` later, received `receive_after_ns` after that.
inline SampleRecord can_sample(const std::string& topic, int frame, Nanos acquisition_ns, Nanos publish_after_ns,
                               Nanos receive_after_ns) {
  SampleRecord s;
  s.topic = topic;
  s.seq = static_cast<std::uint64_t>(frame);
  s.acquisition_ns = acquisition_ns;
  s.publish_ns = s.acquisition_ns + publish_after_ns;
  s.received_ns = s.publish_ns + receive_after_ns;
  return s;
}

inline void drop_part(Input& in, int unit, std::uint32_t part, truth::Fate fate = truth::Fate::kDropped) {
  in.truths[0].parts[static_cast<std::size_t>(unit) * kParts + part].fate = fate;
}

}  // namespace sensor_rig::rig::chaos
