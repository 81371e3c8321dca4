#pragma once
// The fused judge's tests' planted truth (issue 26 item 8): three phase-locked LIDARs (30 rotations
// of 100 ms, scans starting 0, 2 and 5 ms into a rotation), the scans an honest rig publishes, the
// fused sweeps with their members (/rig/sets/fused), and the moves the tests make of them. Its own
// namespace: in a unity batch beside chaos_check_fixture.hpp (one LIDAR, 10 packets a scan), the
// same names must not meet.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos::fused {

inline constexpr Nanos kT0 = 1'800'000'000'000'000'000;
inline constexpr Nanos kPeriod = 100'000'000;
inline constexpr int kRotations = 30;
inline constexpr std::uint32_t kParts = 4;
inline constexpr Nanos kPhase[3] = {0, 2'000'000, 5'000'000};
inline const std::string kNames[3] = {"front", "left", "right"};

inline std::string topic_of(std::size_t i) { return "/sensors/lidar/" + kNames[i] + "/points"; }
inline Nanos acq(std::size_t lidar, int rotation) { return kT0 + rotation * kPeriod + kPhase[lidar]; }
// Each LIDAR's own seq on /rig/stamps: distinct per LIDAR, so that a member naming the wrong topic is told.
inline std::uint64_t seq_of(std::size_t lidar, int rotation) { return 1000 * lidar + static_cast<std::uint64_t>(rotation); }

inline truth::Log lidar_truth(std::size_t i) {
  truth::Log log;
  log.header = truth::Header{kNames[i], "lidar", "VLP-32C", topic_of(i), "scan", "sensor"};
  std::uint64_t seq = 0;
  for (int u = 0; u < kRotations; ++u) {
    log.units.push_back(truth::UnitRecord{u, acq(i, u), acq(i, u), kParts});
    for (std::uint32_t p = 0; p < kParts; ++p) {
      const Nanos t = acq(i, u) + p * (kPeriod / kParts);
      log.parts.push_back(truth::PartRecord{seq++, u, t, 0, t, truth::Fate::kSent, 0});
    }
  }
  return log;
}

inline FusedMember member(std::size_t lidar, int rotation) { return {topic_of(lidar), acq(lidar, rotation), seq_of(lidar, rotation)}; }

inline SampleRecord cloud(std::uint64_t seq, Nanos stamp, std::uint32_t packets, std::uint32_t missing) {
  SampleRecord s;
  s.topic = kFusedCloudTopic;
  s.seq = seq;
  s.acquisition_ns = stamp;
  s.publish_ns = stamp + kPeriod + 5'000'000;
  s.received_ns = s.publish_ns + 1'000'000;
  s.packets = packets;
  s.missing_packets = missing;
  return s;
}

// An honest rig: every scan published, one sweep per rotation holding its three scans, stamped at
// the earliest (the front's), its stamps the sum of its scans'.
inline Input honest() {
  Input in;
  for (std::size_t i = 0; i < 3; ++i) {
    in.truths.push_back(lidar_truth(i));
    for (int u = 0; u < kRotations; ++u) {
      SampleRecord s;
      s.topic = topic_of(i);
      s.seq = seq_of(i, u);
      s.acquisition_ns = acq(i, u);
      s.first_rx_ns = acq(i, u) + 100'000;  // its first packet (sent at its first firing): the LIDAR judge's match
      s.publish_ns = s.acquisition_ns + kPeriod + 5'000'000;
      s.received_ns = s.publish_ns + 1'000'000;
      s.packets = kParts;
      in.samples.push_back(s);
    }
    in.monitor[topic_of(i)] = MonitorTotals{kRotations, 0};
    in.expected[topic_of(i)] = TopicExpectation{kNames[i], 10.0, {}};
  }
  in.fused.enabled = true;
  in.fused.period_ns = kPeriod;
  for (std::size_t i = 0; i < 3; ++i) in.fused.lidar_topics.push_back(topic_of(i));
  for (int u = 0; u < kRotations; ++u) {
    in.fused.sets.push_back(FusedSet{static_cast<std::uint64_t>(u), acq(0, u), {member(0, u), member(1, u), member(2, u)}});
    in.samples.push_back(cloud(static_cast<std::uint64_t>(u), acq(0, u), 3 * kParts, 0));
  }
  in.monitor[kFusedCloudTopic] = MonitorTotals{kRotations, 0};
  in.expected[kFusedCloudTopic] = TopicExpectation{"fusion", 10.0, {"front", "left", "right"}};
  in.epoch_vehicle_ns = kT0;
  in.window_begin_ns = kT0;
  in.window_end_ns = kT0 + kRotations * kPeriod;
  return in;
}

inline SampleRecord& cloud_of(Input& in, std::uint64_t seq) {
  for (auto& s : in.samples)
    if (s.topic == kFusedCloudTopic && s.seq == seq) return s;
  throw std::logic_error("no fused cloud " + std::to_string(seq));
}

inline bool example_says(const Result& r, const std::string& text) {
  for (const auto& e : r.examples)
    if (e.invariant == "fused" && e.topic == kFusedCloudTopic && e.what.find(text) != std::string::npos) return true;
  return false;
}

// Drops LIDAR `lidar`'s scans of rotations [from, to) from its truth and its published scans (it
// made none: stopped, or turning slower).
inline void remove_scans(Input& in, std::size_t lidar, int from, int to) {
  auto& log = in.truths[lidar];
  std::erase_if(log.units, [&](const truth::UnitRecord& u) { return u.unit >= from && u.unit < to; });
  std::erase_if(log.parts, [&](const truth::PartRecord& p) { return p.unit >= from && p.unit < to; });
  std::erase_if(in.samples, [&](const SampleRecord& x) {
    return x.topic == topic_of(lidar) && x.seq >= seq_of(lidar, from) && x.seq < seq_of(lidar, to);
  });
  in.monitor[topic_of(lidar)].received -= static_cast<std::uint64_t>(to - from);
}

// Sweep `u` without `lidar`'s scan; its stamps count its whole scan missing (honest), or nothing.
inline void without(Input& in, int u, std::size_t lidar, bool count_missing = true) {
  auto& members = in.fused.sets[static_cast<std::size_t>(u)].members;
  std::erase_if(members, [&](const FusedMember& m) { return m.topic == topic_of(lidar); });
  auto& c = cloud_of(in, static_cast<std::uint64_t>(u));
  c.packets -= kParts;
  c.missing_packets = count_missing ? kParts : 0;
  if (lidar == 0) c.acquisition_ns = in.fused.sets[static_cast<std::size_t>(u)].stamp = acq(1, u);  // the earliest left
}

// Moves every scan of `lidar` later by `by` (its truth, its published scans, its fused members): a
// rig whose phases are spread, as LIDARs back from restarts on phases of their own are. The sweeps'
// stamps stay the front's (the earliest) for moves of the others under a rotation.
inline void move_lidar(Input& in, std::size_t lidar, Nanos by) {
  for (auto& u : in.truths[lidar].units) u.acq_ns += by, u.dev_ns += by;
  for (auto& part : in.truths[lidar].parts) part.acq_ns += by, part.dev_ns += by, part.tx_ns += by;
  for (auto& x : in.samples)
    if (x.topic == topic_of(lidar)) x.acquisition_ns += by, x.first_rx_ns += by, x.publish_ns += by, x.received_ns += by;
  for (auto& set : in.fused.sets)
    for (auto& m : set.members)
      if (m.topic == topic_of(lidar)) m.stamp += by;
}

// Places LIDAR `lidar`'s scan u (its truth and its published scan) at at(u): a phase of its own that
// may change over time. Its scans must still be where honest() put them.
template <typename At>
inline void place_lidar(Input& in, std::size_t lidar, const At& at) {
  for (auto& u : in.truths[lidar].units) u.dev_ns = u.acq_ns = at(static_cast<int>(u.unit));
  for (auto& part : in.truths[lidar].parts) {
    const Nanos by = at(static_cast<int>(part.unit)) - acq(lidar, static_cast<int>(part.unit));
    part.acq_ns += by, part.dev_ns += by, part.tx_ns += by;
  }
  for (auto& x : in.samples)
    if (x.topic == topic_of(lidar)) {
      const Nanos by = at(static_cast<int>(x.seq - seq_of(lidar, 0))) - x.acquisition_ns;
      x.acquisition_ns += by, x.first_rx_ns += by, x.publish_ns += by, x.received_ns += by;
    }
}

}  // namespace sensor_rig::rig::chaos::fused
