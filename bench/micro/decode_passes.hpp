#pragma once
// The decode loop the LIDAR micro-benchmarks share: a stream of captured or synthetic packets
// pushed through a decoder pass after pass, each pass continuing the timeline (so the decoder
// sees one long, steady stream), scans handed off as a publisher would. Counters: ns_per_packet,
// points_per_s.
#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"

namespace sensor_rig::bench {

struct StampedPacket {
  std::vector<std::byte> bytes;
  Nanos stamp = 0;  // time of the packet's first firing
};

// The packets of a capture that `stamp_of` gives a time (returns nullopt to skip the record);
// empty when the file is absent, so a benchmark can fall back to synthetic packets.
template <class StampOf>
std::vector<StampedPacket> load_capture(const std::string& path, StampOf stamp_of) {
  std::vector<StampedPacket> out;
  if (!std::filesystem::exists(path)) return out;
  lidar::PcapReader reader(path);
  while (auto rec = reader.next()) {
    const std::optional<Nanos> stamp = stamp_of(*rec);
    if (stamp) out.push_back({std::vector<std::byte>(rec->packet.data.begin(), rec->packet.data.end()), *stamp});
  }
  return out;
}

// The time one pass of the stream spans: first to last packet plus one packet interval.
inline Nanos pass_duration(const std::vector<StampedPacket>& packets) {
  return packets.back().stamp - packets.front().stamp + (packets[1].stamp - packets[0].stamp);
}

// Runs the benchmark loop; the caller checks the decoder's stats afterwards. `recycle` returns
// each scan's point buffer to the decoder, as a publisher returning a loan.
template <class Decoder>
void decode_passes(benchmark::State& state, Decoder& dec, const std::vector<StampedPacket>& packets,
                   std::uint16_t port, Nanos pass_ns, bool recycle) {
  std::uint64_t points = 0;
  std::uint64_t pushed = 0;
  Nanos offset = 0;
  for (auto _ : state) {
    for (const auto& p : packets) {
      auto scan = dec.push(lidar::PacketView{p.bytes, p.stamp + offset, port}, p.stamp + offset);
      if (scan) {
        points += scan->points.size();
        benchmark::DoNotOptimize(scan->points.data());
        if (recycle) dec.recycle(std::move(scan->points));
      }
    }
    pushed += packets.size();
    offset += pass_ns;
  }
  state.counters["ns_per_packet"] =
      benchmark::Counter(static_cast<double>(pushed) * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["points_per_s"] = benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
  state.SetItemsProcessed(static_cast<std::int64_t>(pushed));
}

}  // namespace sensor_rig::bench
