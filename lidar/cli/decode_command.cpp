// `rig lidar decode`: a capture -> one PCD per complete scan + one JSON line per scan (SPEC §7).
//
// Scan time: the packet's sensor timestamp (µs since the top of the hour) with the hour taken
// from the pcap record time (the hour closest to the record time), i.e. vehicle time as the
// driver would compute it from a synced sensor. The first scan starts mid-rotation and is not
// written (VeloView numbers it frame 0, so VeloView frame k is scan k-1 here when the capture
// starts mid-rotation); the trailing partial scan is not written either. Both are reported on
// stderr with the drop counts.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "lidar_commands.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/pcd.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar {
namespace {

struct DecodeOptions {
  std::string pcap;
  std::string model;
  std::string calibration;
  std::string returns = "strongest";
  double min_range = 0.0;
  double max_range = 0.0;  // 0 = no limit
  double cut_angle = 0.0;
  std::string out;
};

// Models SPEC §7 names that later issues implement.
constexpr std::string_view kLaterModels[] = {"OS-LEGACY", "OS", "Pandar40P", "PandarXT32"};

std::string supported_models() {
  std::string s;
  for (const auto& m : velodyne::all_models()) s += (s.empty() ? "" : ", ") + std::string(m.name);
  return s;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::UsageError("cannot read calibration file " + path);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

velodyne::DecoderConfig make_config(const DecodeOptions& o) {
  velodyne::DecoderConfig cfg;
  const auto model = velodyne::model_from_name(o.model);
  if (!model) {
    for (auto later : kLaterModels) {
      if (later == o.model) throw cli::UsageError("model " + o.model + " is not supported yet (supported: " + supported_models() + ")");
    }
    throw cli::UsageError("unknown model '" + o.model + "' (supported: " + supported_models() + ")");
  }
  cfg.model = *model;
  if (!o.calibration.empty()) {
    try {
      cfg.calibration = velodyne::parse_calibration(read_text(o.calibration), o.calibration);
    } catch (const velodyne::CalibrationError& e) {
      throw cli::UsageError(e.what());
    }
  }
  cfg.returns = o.returns == "last"   ? velodyne::ReturnSelection::kLast
                : o.returns == "dual" ? velodyne::ReturnSelection::kDual
                                      : velodyne::ReturnSelection::kStrongest;
  cfg.min_range_m = o.min_range;
  if (o.max_range > 0.0) cfg.max_range_m = o.max_range;
  cfg.cut_angle_deg = o.cut_angle;
  return cfg;
}

int run_decode(const DecodeOptions& o) {
  velodyne::DecoderConfig cfg = make_config(o);
  std::unique_ptr<velodyne::Decoder> decoder;
  try {
    decoder = std::make_unique<velodyne::Decoder>(std::move(cfg));
  } catch (const std::exception& e) {  // calibration or option out of range
    throw cli::UsageError(e.what());
  }
  if (!std::filesystem::is_regular_file(o.pcap)) throw cli::UsageError("no such capture file: " + o.pcap);
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec || !std::filesystem::is_directory(o.out)) {
    std::fprintf(stderr, "error: cannot create output directory %s: %s\n", o.out.c_str(), ec.message().c_str());
    return cli::kRuntime;
  }

  PcapReader reader(o.pcap);  // PcapError -> exit 1 with its message
  std::uint64_t position_packets = 0;
  std::uint64_t written = 0;
  while (auto rec = reader.next()) {
    const auto& pkt = rec->packet;
    if (pkt.dst_port == velodyne::kPositionPort || pkt.data.size() == velodyne::kPositionPacketSize) {
      ++position_packets;
      continue;
    }
    const auto info = velodyne::read_packet_info(pkt.data);
    const Nanos stamp = info ? velodyne::sensor_time_to_ns(info->sensor_time_us, pkt.rx_ns) : pkt.rx_ns;
    auto scan = decoder->push(pkt, stamp);
    if (!scan) continue;
    char name[32];
    std::snprintf(name, sizeof name, "scan_%06llu.pcd", static_cast<unsigned long long>(scan->seq));
    write_pcd((std::filesystem::path(o.out) / name).string(), scan->points);
    std::printf("{\"scan\":%llu,\"points\":%zu,\"stamp_ns\":%lld,\"packets\":%u,\"dropped\":%u}\n",
                static_cast<unsigned long long>(scan->seq), scan->points.size(), static_cast<long long>(scan->stamp),
                scan->packets, scan->dropped);
    ++written;
  }
  std::fflush(stdout);
  const auto tail = decoder->flush();
  const auto& st = decoder->stats();
  const auto& ps = reader.stats();
  std::string drops;
  for (std::size_t i = 1; i < st.by_status.size(); ++i) {
    if (st.by_status[i] == 0) continue;
    drops += std::string(drops.empty() ? "" : ", ") + to_string(static_cast<PacketStatus>(i)) + " " +
             std::to_string(st.by_status[i]);
  }
  std::fprintf(stderr,
               "decoded %llu scans from %llu data packets (%llu dropped%s%s); %llu position packets; "
               "partial scans not written: first %llu, last %zu points; pcap: %llu records, %llu non-UDP, "
               "%llu fragments, %llu truncated, %llu bad\n",
               static_cast<unsigned long long>(written), static_cast<unsigned long long>(st.packets),
               static_cast<unsigned long long>(st.dropped()), drops.empty() ? "" : ": ", drops.c_str(),
               static_cast<unsigned long long>(position_packets),
               static_cast<unsigned long long>(st.partial_scans_discarded), tail ? tail->points.size() : 0,
               static_cast<unsigned long long>(ps.records), static_cast<unsigned long long>(ps.not_udp),
               static_cast<unsigned long long>(ps.fragments), static_cast<unsigned long long>(ps.truncated),
               static_cast<unsigned long long>(ps.bad));
  if (!reader.error().empty()) {
    // A capture cut short (recorder killed) still yields every scan before the damage.
    std::fprintf(stderr, "%s: %s\n", ps.records == 0 ? "error" : "warning", reader.error().c_str());
    if (ps.records == 0) return cli::kRuntime;
  }
  return cli::kOk;
}

}  // namespace

void register_decode_command(CLI::App& lidar, cli::Context& ctx) {
  auto opts = std::make_shared<DecodeOptions>();
  auto* cmd = lidar.add_subcommand("decode", "Decode a capture into PCD files, one per complete scan");
  cmd->add_option("--pcap", opts->pcap, "capture file (pcap/pcapng)")->required();
  cmd->add_option("--model", opts->model, "VLP-16, VLP-32C or HDL-32E")->required();
  cmd->add_option("--calibration", opts->calibration, "ROS velodyne YAML or VeloView XML (default: manual values)");
  cmd->add_option("--return", opts->returns, "strongest, last or dual")
      ->check(CLI::IsMember({"strongest", "last", "dual"}))
      ->capture_default_str();
  cmd->add_option("--min-range", opts->min_range, "drop points closer than M metres")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--max-range", opts->max_range, "drop points farther than M metres (default: no limit)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--cut-angle", opts->cut_angle, "azimuth in degrees where a scan ends (default 0: the wrap)")
      ->check(CLI::Range(0.0, 359.99))
      ->capture_default_str();
  cmd->add_option("--out", opts->out, "output directory for scan_NNNNNN.pcd")->required();
  cmd->callback([opts, &ctx] { ctx.exit_code = run_decode(*opts); });
}

}  // namespace sensor_rig::lidar
