#include "roudi_pools.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "rig_config.hpp"
#include "sensor_rig/camera/pixel_format.hpp"
#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"

namespace sensor_rig::rig {
namespace {

constexpr std::uint64_t kPointStep = 24;        // PointCloud2 layout of the rig (README)
constexpr std::uint64_t kMessageOverhead = 1024;  // CDR header, stamp, frame_id, fields / encoding
// An Ouster whose frame is unknown (no metadata, not synthetic) is sized as the largest frame it
// can send (OS 128 x 2048).
constexpr std::uint64_t kOusterMaxPoints = 128ULL * 2048ULL;

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The most points a scan of this LIDAR can carry: one full rotation of every laser (both returns
// when dual) at the speed it is sized for (drivers::sizing_rpm: the mock's, the config's `rpm`, else
// the slowest a sensor can be set to; the models' figures are for 600 rpm). Sized at 600 rpm, a
// real sensor set to 300 rpm failed every write (issue 26 item 7).
std::uint64_t max_scan_points(const LidarConfig& l) {
  const std::uint64_t returns = l.returns == lidar::ReturnSelection::kDual ? 2 : 1;
  const double slower = std::max(1.0, 600.0 / drivers::sizing_rpm(l));
  const auto at_rpm = [&](int typical) {
    return static_cast<std::uint64_t>(std::ceil(static_cast<double>(typical) * slower)) * returns;
  };
  if (const auto m = lidar::velodyne::model_from_name(l.model)) return at_rpm(lidar::velodyne::model_info(*m).typical_points_per_scan);
  if (const auto m = lidar::hesai::model_from_name(l.model)) return at_rpm(lidar::hesai::model_info(*m).typical_points_per_scan);
  if (lidar::mock::is_ouster_model(l.model)) {
    try {
      // Without metadata a synthetic Ouster renders the nominal sensor of its mock options (rig up
      // writes that metadata for the driver): 32 x 1024 at 600 rpm, not 128 x 2048 (436 MB of shm).
      const bool nominal = l.metadata.empty() && l.mock.kind == LidarMockConfig::Kind::kSynthetic;
      if (l.metadata.empty() && !nominal) return kOusterMaxPoints * returns;
      const auto md = nominal ? lidar::mock::synthetic_ouster_metadata(drivers::synthetic_mock_options(l))
                              : lidar::ouster::parse_metadata(read_file(l.metadata), l.metadata);
      // A single-return profile gives one echo whatever is selected.
      const std::uint64_t echoes = std::min<std::uint64_t>(returns, lidar::ouster::profile_spec(md.profile).returns);
      return static_cast<std::uint64_t>(md.columns_per_frame) * static_cast<std::uint64_t>(md.pixels_per_column) * echoes;
    } catch (const std::exception&) {
      return kOusterMaxPoints * returns;  // the config check reports the file itself
    }
  }
  return 0;
}

ShmTopicLoad load_of(std::string topic, std::uint64_t sample_bytes, const dds::QosSpec& qos, int readers) {
  ShmTopicLoad t;
  t.topic = std::move(topic);
  t.max_sample_bytes = sample_bytes;
  t.depth = qos.depth > 0 ? qos.depth : 16;  // keep-all: what a reader typically holds, not a bound
  t.pub_history = qos.durability == dds::QosSpec::Durability::kTransientLocal ? t.depth : 0;
  t.readers = readers;
  return t;
}

std::uint64_t chunks_for(const ShmTopicLoad& t) {
  const auto count = [](int n) { return static_cast<std::uint64_t>(n); };
  const std::uint64_t held = count(t.writers) * count(1 + t.pub_history) + count(t.readers) * count(t.depth + 1);
  return (held * 3 + 1) / 2 + 2;
}

}  // namespace

std::vector<ShmTopicLoad> shm_topic_loads(const RigConfig& cfg, int extra_subscribers) {
  std::vector<ShmTopicLoad> loads;
  std::uint64_t fused_points = 0;
  const int cloud_readers = extra_subscribers + (cfg.fusion.enabled ? 1 : 0);
  for (const auto& l : cfg.lidars) {
    const std::uint64_t points = max_scan_points(l);
    fused_points += points;
    loads.push_back(load_of("/sensors/lidar/" + l.name + "/points", points * kPointStep + kMessageOverhead, l.qos,
                            cloud_readers));
  }
  if (cfg.fusion.enabled)
    loads.push_back(load_of(drivers::kFusedTopic, fused_points * kPointStep + kMessageOverhead, cfg.fusion.qos,
                            extra_subscribers));
  for (const auto& c : cfg.cameras) {
    const std::uint64_t pixels = std::uint64_t{c.source.width} * c.source.height;
    const std::string base = "/sensors/camera/" + c.name;
    loads.push_back(load_of(base + "/image_raw", pixels * camera::bytes_per_pixel(c.source.format) + kMessageOverhead,
                            c.qos, extra_subscribers));
    if (c.outputs.color) loads.push_back(load_of(base + "/image_color", pixels * 3 + kMessageOverhead, c.qos, extra_subscribers));
    // JPEG of a camera image stays below one byte per pixel (a larger one takes a larger pool).
    if (c.outputs.compressed)
      loads.push_back(load_of(base + "/image_raw/compressed", pixels + kMessageOverhead, c.qos, extra_subscribers));
  }
  return loads;
}

std::uint64_t chunk_size_for(std::uint64_t sample_bytes) {
  const std::uint64_t n = sample_bytes + kChunkOverhead;
  if (n <= kSmallPool) return kSmallPool;
  std::uint64_t octave = 1;
  while (octave * 2 <= n) octave *= 2;
  const std::uint64_t step = octave / 8;
  return (n + step - 1) / step * step;
}

std::vector<Mempool> size_mempools(const std::vector<ShmTopicLoad>& loads) {
  std::map<std::uint64_t, std::uint64_t> by_size{{kSmallPool, 2048}, {kMediumPool, 512}};
  for (const auto& t : loads) {
    const std::uint64_t size = chunk_size_for(t.max_sample_bytes);
    by_size[std::max(size, kMediumPool)] += chunks_for(t);
  }
  std::vector<Mempool> pools;
  pools.reserve(by_size.size());
  for (const auto& [size, count] : by_size) pools.push_back({size, count});
  return pools;
}

std::vector<Mempool> rig_mempools(const RigConfig& cfg) {
  if (!cfg.shm_mempools.empty()) return cfg.shm_mempools;
  return size_mempools(shm_topic_loads(cfg, cfg.shm_subscribers));
}

std::uint64_t mempools_bytes(const std::vector<Mempool>& pools) {
  std::uint64_t total = 0;
  for (const auto& p : pools) total += p.size * p.count;
  return total;
}

std::string roudi_toml(const std::vector<Mempool>& pools, const std::string& comment) {
  std::ostringstream o;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) o << "# " << line << "\n";
  o << "[general]\nversion = 1\n\n[[segment]]\n";
  for (const auto& p : pools) o << "\n[[segment.mempool]]\nsize = " << p.size << "\ncount = " << p.count << "\n";
  return o.str();
}

std::vector<Mempool> parse_roudi_toml(const std::string& text) {
  std::vector<Mempool> pools;
  static const std::regex kKeyValue(R"(^\s*(size|count)\s*=\s*([0-9]+)\s*(#.*)?$)");
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.find("[[segment.mempool]]") != std::string::npos) {
      pools.emplace_back();
      continue;
    }
    std::smatch m;
    if (pools.empty() || !std::regex_match(line, m, kKeyValue)) continue;
    (m[1] == "size" ? pools.back().size : pools.back().count) = std::stoull(m[2]);
  }
  std::sort(pools.begin(), pools.end(), [](const Mempool& a, const Mempool& b) { return a.size < b.size; });
  return pools;
}

std::vector<Mempool> iceoryx_default_mempools() {
  return {{128, 10000}, {1024, 5000}, {16384, 1000}, {131072, 200}, {524288, 50}, {1048576, 30}, {4194304, 10}};
}

std::string mempools_shortfall(const std::vector<Mempool>& required, const std::vector<Mempool>& available) {
  std::map<std::uint64_t, std::uint64_t> needed;  // available size -> chunks required of it
  std::string problems;
  const auto add = [&](const std::string& p) { problems += (problems.empty() ? "" : "; ") + p; };
  for (const auto& r : required) {
    auto fit = std::find_if(available.begin(), available.end(), [&](const Mempool& a) { return a.size >= r.size; });
    if (fit == available.end()) {
      add("no pool holds " + std::to_string(r.size) + " B chunks (largest " +
          (available.empty() ? std::string("none") : std::to_string(available.back().size) + " B") + ")");
      continue;
    }
    needed[fit->size] += r.count;
  }
  for (const auto& a : available) {
    const auto n = needed.find(a.size);
    if (n != needed.end() && n->second > a.count)
      add("the " + std::to_string(a.size) + " B pool has " + std::to_string(a.count) + " chunks, this rig needs " +
          std::to_string(n->second));
  }
  return problems;
}

std::string roudi_config_file_of(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
  std::vector<std::string> args;
  for (std::string a; std::getline(in, a, '\0');) args.push_back(a);
  for (std::size_t i = 0; i < args.size(); ++i) {
    if ((args[i] == "-c" || args[i] == "--config-file") && i + 1 < args.size()) return args[i + 1];
    if (args[i].rfind("--config-file=", 0) == 0) return args[i].substr(14);
  }
  return {};
}

}  // namespace sensor_rig::rig
