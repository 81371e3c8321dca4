// `rig lidar decode`: a capture -> one PCD per complete scan + one JSON line per scan (SPEC §7).
//
// Any model of the registry (scan_decoder.hpp). Scan time: the packet's own sensor time — Velodyne:
// µs since the top of the hour with the hour taken from the pcap record time (the hour closest to
// it); sensors with absolute time (Ouster, Hesai): that time — i.e. vehicle time as the driver
// computes it for a synced sensor; packets without a usable time: the record time. The first scan starts mid-rotation and is not
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
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar {
namespace {

struct DecodeOptions {
  std::string pcap;
  std::string model;
  std::string calibration;
  std::string metadata;
  std::string returns = "strongest";
  double min_range = 0.0;
  double max_range = 0.0;  // 0 = no limit
  double cut_angle = 0.0;
  std::string out;
};

std::string read_text(const std::string& path, const char* what) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::UsageError(std::string("cannot read ") + what + " file " + path);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::unique_ptr<ScanDecoder> make_cli_decoder(const DecodeOptions& o) {
  DecoderOptions d;
  d.model = o.model;
  if (!o.calibration.empty()) {
    d.calibration_text = read_text(o.calibration, "calibration");
    d.calibration_name = o.calibration;
  }
  if (!o.metadata.empty()) {
    d.metadata_text = read_text(o.metadata, "metadata");
    d.metadata_name = o.metadata;
  }
  d.returns = o.returns;
  d.min_range_m = o.min_range;
  if (o.max_range > 0.0) d.max_range_m = o.max_range;
  d.cut_angle_deg = o.cut_angle;
  try {
    return make_decoder(d);
  } catch (const DecoderConfigError& e) {  // unknown model, calibration, options
    throw cli::UsageError(e.what());
  }
}

// Vehicle time of the packet's first firing, from the sensor's own time where the packet has one.
Nanos packet_stamp(const ScanDecoder& dec, const PacketView& pkt) {
  const auto t = dec.packet_time(pkt.data);
  switch (t.kind) {
    case SensorTime::Kind::kMicrosSinceHour:
      return velodyne::sensor_time_to_ns(static_cast<std::uint32_t>(t.value), pkt.rx_ns);
    case SensorTime::Kind::kAbsoluteNs:
      return t.value;
    case SensorTime::Kind::kNone:
      break;
  }
  return pkt.rx_ns - dec.packet_span_ns();
}

int run_decode(const DecodeOptions& o) {
  const auto decoder = make_cli_decoder(o);
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
    if (!decoder->is_data_packet(pkt)) {
      ++position_packets;
      continue;
    }
    auto scan = decoder->push(pkt, packet_stamp(*decoder, pkt));
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
  const auto st = decoder->counters();
  const auto& ps = reader.stats();
  std::string drops;
  for (std::size_t i = 1; i < st.by_status.size(); ++i) {
    if (st.by_status[i] == 0) continue;
    drops += std::string(drops.empty() ? "" : ", ") + to_string(static_cast<PacketStatus>(i)) + " " +
             std::to_string(st.by_status[i]);
  }
  std::fprintf(stderr,
               "decoded %llu scans from %llu data packets (%llu dropped%s%s); %llu other (position/IMU) packets; "
               "partial scans not written: %llu, last %zu points; pcap: %llu records, %llu non-UDP, "
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
  cmd->add_option("--model", opts->model, "sensor model: " + implemented_model_names())->required();
  cmd->add_option("--calibration", opts->calibration,
                  "calibration file (Velodyne: ROS YAML or VeloView XML; default: the manual's values)");
  cmd->add_option("--metadata", opts->metadata, "sensor metadata JSON (Ouster models)");
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
