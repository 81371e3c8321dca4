#include "sensor_rig/bench/perf/spec.hpp"

#include <cmath>
#include <cstdio>

#include "sensor_rig/common/cli_context.hpp"

namespace sensor_rig::bench::perf {
namespace {
struct SizeClass {
  const char* label;
  std::uint32_t bytes;
};
constexpr SizeClass kSizes[] = {{"0B", 0},           {"16B", 16},          {"64kB", 65536},
                                {"512kB", 524288},   {"1MB", 1048576},     {"2MB", 2097152}};
}  // namespace

std::uint32_t parse_size(const std::string& text) {
  for (const auto& s : kSizes) {
    if (text == s.label) return s.bytes;
  }
  // Aliases used by the paper's Table 1 and plain byte counts of a class.
  if (text == "Struct16") return 16;
  if (text == "Array64k") return 65536;
  if (text == "PointCloud1m") return 1048576;
  for (const auto& s : kSizes) {
    if (text == std::to_string(s.bytes)) return s.bytes;
  }
  throw cli::UsageError("unknown size '" + text + "' (one of 0B 16B 64kB 512kB 1MB 2MB)");
}

std::string size_label(std::uint32_t bytes) {
  for (const auto& s : kSizes) {
    if (s.bytes == bytes) return s.label;
  }
  return std::to_string(bytes) + "B";
}

bool is_size_class(std::uint32_t bytes) {
  for (const auto& s : kSizes) {
    if (s.bytes == bytes) return true;
  }
  return false;
}

Transport parse_transport(const std::string& text) {
  if (text == "udp") return Transport::kUdp;
  if (text == "udp-tuned") return Transport::kUdpTuned;
  if (text == "shm") return Transport::kShm;
  throw cli::UsageError("unknown transport '" + text + "' (udp, udp-tuned, shm)");
}

std::string to_string(Transport t) {
  switch (t) {
    case Transport::kUdp: return "udp";
    case Transport::kUdpTuned: return "udp-tuned";
    case Transport::kShm: return "shm";
  }
  return "?";
}

Message parse_message(const std::string& text) {
  if (text == "fixed") return Message::kFixed;
  if (text == "seq") return Message::kSeq;
  if (text == "pointcloud2") return Message::kPointCloud2;
  throw cli::UsageError("unknown message kind '" + text + "' (fixed, seq, pointcloud2)");
}

std::string to_string(Message m) {
  switch (m) {
    case Message::kFixed: return "fixed";
    case Message::kSeq: return "seq";
    case Message::kPointCloud2: return "pointcloud2";
  }
  return "?";
}

ReaderMode parse_reader_mode(const std::string& text) {
  if (text == "copy") return ReaderMode::kCopy;
  if (text == "view") return ReaderMode::kView;
  throw cli::UsageError("unknown reader mode '" + text + "' (copy, view)");
}

std::string to_string(ReaderMode r) { return r == ReaderMode::kView ? "view" : "copy"; }

std::uint32_t RunSpec::count() const {
  return static_cast<std::uint32_t>(std::llround(rate_hz * duration_s));
}

std::string RunSpec::label() const {
  char buf[128];
  std::snprintf(buf, sizeof buf, "T%d N=%d %s %gHz %s", topology, nodes, size_label(size).c_str(), rate_hz,
                to_string(transport).c_str());
  std::string label = message == Message::kFixed ? std::string(buf) : std::string(buf) + " " + to_string(message);
  return reader == ReaderMode::kView ? label + " view" : label;
}

void RunSpec::validate() const {
  if (topology < 1 || topology > 3) throw cli::UsageError("--topology must be 1, 2 or 3");
  if (nodes < 2 || nodes > 128) throw cli::UsageError("--nodes must be 2..128");
  if (topology == 1 && nodes % 2 != 0) throw cli::UsageError("topology 1 pairs publishers and subscribers: --nodes must be even");
  if (!is_size_class(size)) throw cli::UsageError("size must be one of 0B 16B 64kB 512kB 1MB 2MB");
  if (!(rate_hz > 0.0) || rate_hz > 10000.0) throw cli::UsageError("--rate must be in (0, 10000] Hz");
  if (!(duration_s > 0.0) || duration_s > 3600.0) throw cli::UsageError("--duration must be in (0, 3600] s");
  if (count() == 0) throw cli::UsageError("rate x duration gives no message");
  if (domain > 232) throw cli::UsageError("--domain must be 0..232");
  if (depth < 1 || depth > 1000) throw cli::UsageError("--depth must be 1..1000");
  if (rt_priority < 0 || rt_priority > 99) throw cli::UsageError("--rt-priority must be 0..99");
  if (reader == ReaderMode::kView && message != Message::kPointCloud2) {
    throw cli::UsageError("--reader view reads PointCloud2 only (--message pointcloud2)");
  }
  if (out.empty()) throw cli::UsageError("--out DIR is required");
}

int publisher_count(const RunSpec& spec) {
  switch (spec.topology) {
    case 1: return spec.nodes / 2;
    case 2: return 1;
    default: return spec.nodes - 1;
  }
}

std::vector<NodePlan> plan_nodes(const RunSpec& spec) {
  std::vector<NodePlan> plan;
  const int pubs = publisher_count(spec);
  const int subs = spec.topology == 3 ? 1 : spec.nodes - pubs;
  plan.reserve(static_cast<std::size_t>(pubs) + static_cast<std::size_t>(subs));
  for (int p = 0; p < pubs; ++p) {
    plan.push_back({static_cast<int>(plan.size()), Role::kPublisher, {p}, spec.topology == 2 ? subs : 1});
  }
  for (int s = 0; s < subs; ++s) {
    NodePlan n{static_cast<int>(plan.size()), Role::kSubscriber, {}, 0};
    if (spec.topology == 1) {
      n.topics = {s};
    } else if (spec.topology == 2) {
      n.topics = {0};
    } else {
      for (int p = 0; p < pubs; ++p) n.topics.push_back(p);
    }
    n.expected_matches = static_cast<int>(n.topics.size());
    plan.push_back(std::move(n));
  }
  return plan;
}

}  // namespace sensor_rig::bench::perf
