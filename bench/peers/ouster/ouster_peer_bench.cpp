// The peer side of scripts/bench_ouster_peer.sh: what a user of ouster-sdk does per packet, timed
// on the same packets bench_lidar_ouster decodes. FrameBatcher batches the packets into a
// LidarFrame; each completed frame goes through an XYZLut (sensor frame: use_extrinsics=false).
// Built against an ouster-sdk checkout by this folder's CMakeLists.txt; not part of the project.
//
//   ouster_peer_bench PACKETS METADATA.json [--seconds S] [--float] [--compare OURS.xyz]
// PACKETS, OURS.xyz: what bench_lidar_ouster exports (RIG_BENCH_OUSTER_EXPORT): u32 little-endian
// length + packet bytes, repeated; our first scan's x y z (float, m). --float: XYZLutT<float>
// instead of the default XYZLut (double). --compare: the first complete frame's points with
// range != 0, column by column (measurement id order), beam by beam (the order our decoder emits
// them in), against ours: counts, largest distance, points more than 1 mm apart.
// Prints one line: name, packets, frames, points per frame, and the thread CPU time per packet
// (mean over all passes, as Google Benchmark's counters in bench_lidar_ouster; and the median pass).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "ouster/core/lidar_frame.h"
#include "ouster/core/packet.h"
#include "ouster/core/sensor_info.h"
#include "ouster/core/xyzlut.h"

namespace core = ouster::sdk::core;

namespace {

double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<core::LidarPacket> read_packets(const std::string& path) {
  const std::string bytes = read_text(path);
  std::vector<core::LidarPacket> out;
  std::size_t at = 0;
  while (at + 4 <= bytes.size()) {
    std::uint32_t n = 0;
    std::memcpy(&n, bytes.data() + at, 4);  // little-endian host (x86)
    at += 4;
    if (at + n > bytes.size()) throw std::runtime_error(path + ": truncated packet");
    core::LidarPacket p(static_cast<int>(n));
    std::memcpy(p.buf.data(), bytes.data() + at, n);
    // A receive time, as a packet source sets it: the batcher counts a frame complete only when
    // every packet slot has a non-zero one.
    p.host_timestamp = 1 + out.size();
    out.push_back(std::move(p));
    at += n;
  }
  return out;
}

// Returns false when the clouds differ (count, or any point > 1 mm apart).
template <class Lut>
bool compare_points(const std::string& ours_path, const core::LidarFrame& frame, const Lut& lut) {
  const std::string bytes = read_text(ours_path);
  std::vector<float> ours(bytes.size() / sizeof(float));
  std::memcpy(ours.data(), bytes.data(), ours.size() * sizeof(float));
  const auto xyz = lut(frame);
  const auto range = frame.field<std::uint32_t>(core::ChanField::RANGE);
  const auto w = static_cast<Eigen::Index>(frame.w);
  std::size_t n = 0;
  std::size_t over = 0;
  double worst = 0.0;
  for (Eigen::Index c = 0; c < w; ++c) {
    for (Eigen::Index r = 0; r < range.rows(); ++r) {
      if (range(r, c) == 0) continue;
      if (3 * n + 2 < ours.size()) {
        double d2 = 0.0;
        for (Eigen::Index k = 0; k < 3; ++k) {
          const double d = static_cast<double>(xyz(r * w + c, k)) - static_cast<double>(ours[3 * n + static_cast<std::size_t>(k)]);
          d2 += d * d;
        }
        worst = std::max(worst, std::sqrt(d2));
        if (d2 > 1e-6) ++over;
      }
      ++n;
    }
  }
  const std::size_t n_ours = ours.size() / 3;
  std::printf("compare points peer=%zu ours=%zu max_distance_mm=%.4f over_1mm=%zu\n", n, n_ours, worst * 1e3, over);
  return n == n_ours && over == 0;
}

template <class Lut>
int run(const std::vector<core::LidarPacket>& packets, const std::shared_ptr<core::SensorInfo>& info,
        double seconds, const std::string& compare_with, const char* name) {
  const Lut lut(*info, /*use_extrinsics=*/false);
  core::FrameBatcher batcher(*info);
  core::LidarFrame frame(info);
  std::size_t frames = 0;
  std::size_t points = 0;
  double sink = 0.0;  // keeps the XYZ live
  bool same = true;
  std::vector<double> pass_us;
  double total_us = 0.0;
  while (total_us < seconds * 1e6 || pass_us.size() < 5) {
    // The capture is one frame replayed: its frame id repeats, so the batcher starts over each pass.
    batcher.reset();
    const double t0 = thread_cpu_us();
    for (const auto& p : packets) {
      if (batcher.batch(p, frame)) {
        const auto xyz = lut(frame);
        sink += static_cast<double>(xyz(xyz.rows() - 1, 0));
        ++frames;
      }
    }
    pass_us.push_back(thread_cpu_us() - t0);
    total_us += pass_us.back();
    if (points == 0 && frames > 0) {  // the first complete frame
      points = static_cast<std::size_t>((frame.field<std::uint32_t>(core::ChanField::RANGE).array() != 0).count());
      if (!compare_with.empty()) same = compare_points(compare_with, frame, lut);
    }
  }
  if (frames == 0) {
    std::cerr << "no complete frame (dropped " << batcher.dropped_packets() << ")\n";
    return 1;
  }
  std::nth_element(pass_us.begin(), pass_us.begin() + static_cast<std::ptrdiff_t>(pass_us.size() / 2), pass_us.end());
  const double median = pass_us[pass_us.size() / 2];
  const auto n = static_cast<double>(packets.size());
  std::printf("peer %s packets=%zu passes=%zu frames=%zu points_per_frame=%zu us_per_packet=%.3f median_pass_us_per_packet=%.3f sink=%g\n",
              name, packets.size(), pass_us.size(), frames, points, total_us / (n * static_cast<double>(pass_us.size())),
              median / n, sink);
  return same ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: ouster_peer_bench PACKETS METADATA.json [--seconds S] [--float] [--compare OURS.xyz]\n";
    return 2;
  }
  double seconds = 2.0;
  bool use_float = false;
  std::string compare_with;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seconds" && i + 1 < argc) seconds = std::stod(argv[++i]);
    else if (a == "--float") use_float = true;
    else if (a == "--compare" && i + 1 < argc) compare_with = argv[++i];
    else {
      std::cerr << "unknown argument: " << a << "\n";
      return 2;
    }
  }
  try {
    const auto packets = read_packets(argv[1]);
    const auto info = std::make_shared<core::SensorInfo>(read_text(argv[2]));
    return use_float ? run<core::XYZLutT<float>>(packets, info, seconds, compare_with, "XYZLutT<float>")
                     : run<core::XYZLut>(packets, info, seconds, compare_with, "XYZLut(double)");
  } catch (const std::exception& e) {
    std::cerr << "ouster_peer_bench: " << e.what() << "\n";
    return 1;
  }
}
