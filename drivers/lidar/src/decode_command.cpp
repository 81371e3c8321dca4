// `rig lidar decode`: a capture -> one PCD per complete scan + one JSON line per scan (SPEC §7).
// The offline LIDAR node: pcap source -> timesync (the node's PacketStamper) -> decoder -> PCD.
//
// Any model of the registry (scan_decoder.hpp). Scan time: the packet's own sensor time — Velodyne:
// µs since the top of the hour with the hour taken from the pcap record time (the hour closest to
// it); sensors with absolute time (Ouster, Hesai): that time — i.e. vehicle time as the driver
// computes it for a synced sensor; packets without a usable time: the record time. The first scan starts mid-rotation and is not
// written (VeloView numbers it frame 0, so VeloView frame k is scan k-1 here when the capture
// starts mid-rotation); the trailing partial scan is not written either. Both are reported on
// stderr with the drop counts.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/drivers/lidar/lidar_stamping.hpp"
#include "sensor_rig/lidar/decoder_files.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/pcd.hpp"
#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

namespace sensor_rig::drivers {
namespace {

using namespace sensor_rig::lidar;  // NOLINT(google-build-using-namespace): the command of the lidar area

struct DecodeOptions {
  std::string pcap;
  std::string model;
  std::string calibration;
  std::string metadata;
  ReturnSelection returns = ReturnSelection::kStrongest;
  double min_range = 0.0;
  double max_range = 0.0;  // 0 = no limit
  double cut_angle = 0.0;
  std::vector<double> fov;  // start, end (degrees); empty = the whole turn
  AzimuthInterpolation azimuth = AzimuthInterpolation::kPerLaser;
  std::string out;
};

// A range bound must be a finite number (CLI11 reads "nan" and "inf" as doubles).
void check_finite(const char* option, double v) {
  if (!std::isfinite(v)) throw cli::UsageError(std::string(option) + ": " + std::to_string(v) + " is not a finite number of metres");
}

std::unique_ptr<ScanDecoder> make_cli_decoder(const DecodeOptions& o) {
  DecoderOptions d;
  d.model = o.model;
  try {
    apply_decoder_files(read_decoder_files(o.calibration, o.metadata), d);
  } catch (const DecoderFileError& e) {
    throw cli::UsageError(e.what());
  }
  d.returns = o.returns;
  check_finite("--min-range", o.min_range);
  check_finite("--max-range", o.max_range);
  d.min_range_m = o.min_range;
  if (o.max_range > 0.0) d.max_range_m = o.max_range;
  d.cut_angle_deg = o.cut_angle;
  d.azimuth = o.azimuth;
  if (!o.fov.empty()) {
    if (o.fov.size() != 2 || !(o.fov[0] >= 0.0 && o.fov[0] <= 360.0 && o.fov[1] >= 0.0 && o.fov[1] <= 360.0))
      throw cli::UsageError("--fov: need START,END in [0, 360] degrees (the sensor's FOV setting, clockwise)");
    d.fov_start_deg = o.fov[0];
    d.fov_end_deg = o.fov[1];
  }
  try {
    return make_decoder(d);
  } catch (const DecoderConfigError& e) {  // unknown model, calibration, options
    throw cli::UsageError(e.what());
  }
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

  // The LIDAR node's stamping policy, offline: the sensor's own time as is (no mapping: a
  // capture has no live vehicle clock to map to), the hour from the record time.
  timesync::PacketStamper stamper(stamper_config(timesync::TimeSource::kSensor, timesync::HourSource::kHost,
                                                 timesync::Correction::kNever, decoder->packet_span_ns()));
  PcapReader reader(o.pcap);  // PcapError -> exit 1 with its message
  std::uint64_t position_packets = 0;
  std::uint64_t written = 0;
  std::size_t data_size = 0;  // size of the last data packet (for the wrong-size error)
  while (auto rec = reader.next()) {
    const auto& pkt = rec->packet;
    if (!decoder->is_data_packet(pkt)) {
      ++position_packets;
      continue;
    }
    data_size = pkt.data.size();
    auto scan = decoder->push(pkt, stamper.stamp(device_packet(decoder->packet_time(pkt.data), pkt.rx_ns)));
    if (!scan) continue;
    char name[32];
    std::snprintf(name, sizeof name, "scan_%06llu.pcd", static_cast<unsigned long long>(scan->seq));
    write_pcd((std::filesystem::path(o.out) / name).string(), scan->points);
    std::printf(
        "{\"scan\":%llu,\"points\":%zu,\"stamp_ns\":%lld,\"packets\":%u,\"dropped\":%u,\"missing_packets\":%u}\n",
        static_cast<unsigned long long>(scan->seq), scan->points.size(), static_cast<long long>(scan->stamp),
        scan->packets, scan->dropped, scan->missing_packets);
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
  const auto wrong_size = st.by_status[static_cast<std::size_t>(PacketStatus::kWrongSize)];
  if (st.packets > 0 && wrong_size == st.packets) {
    // Not one packet has the size the model/metadata say: the metadata (columns, pixels, profile)
    // or the model does not describe this capture. Garbage would follow: refuse.
    throw cli::UsageError("every one of the " + std::to_string(st.packets) + " data packets is " +
                          std::to_string(data_size) + " bytes, which model " + o.model +
                          (o.metadata.empty() ? std::string() : " with metadata " + o.metadata) +
                          " does not describe (columns/pixels per packet, profile): wrong model or metadata for this capture");
  }
  std::fprintf(stderr,
               "decoded %llu scans from %llu data packets (%llu dropped%s%s); missing packets %llu, implausible "
               "azimuth/frame steps %llu, time jumps %llu; %llu other (position/IMU) packets; "
               "partial scans not written: %llu, last %zu points; pcap: %llu records, %llu non-UDP, "
               "%llu fragments, %llu truncated, %llu bad\n",
               static_cast<unsigned long long>(written), static_cast<unsigned long long>(st.packets),
               static_cast<unsigned long long>(st.dropped()), drops.empty() ? "" : ": ", drops.c_str(),
               static_cast<unsigned long long>(st.missing_packets), static_cast<unsigned long long>(st.implausible_steps),
               static_cast<unsigned long long>(st.time_jumps), static_cast<unsigned long long>(position_packets),
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

// Adds `decode` to the `rig lidar` group the lidar area made (rig calls the area first).
void register_lidar_cli(CLI::App& app, cli::Context& ctx) {
  const auto found = app.get_subcommands([](CLI::App* a) { return a->get_name() == "lidar"; });
  CLI::App* group = found.empty() ? nullptr : found.front();
  if (group == nullptr) group = app.add_subcommand("lidar", "LIDAR tools")->require_subcommand(1);
  CLI::App& lidar = *group;
  auto opts = std::make_shared<DecodeOptions>();
  auto* cmd = lidar.add_subcommand("decode", "Decode a capture into PCD files, one per complete scan");
  cmd->add_option("--pcap", opts->pcap, "capture file (pcap/pcapng)")->required();
  cmd->add_option("--model", opts->model, "sensor model: " + implemented_model_names())->required();
  cmd->add_option("--calibration", opts->calibration,
                  "calibration file (Velodyne: ROS YAML or VeloView XML; default: the manual's values)");
  cmd->add_option("--metadata", opts->metadata, "sensor metadata JSON (Ouster models)");
  cmd->add_option("--return", "strongest, last or dual (default strongest)")
      ->check(CLI::IsMember({"strongest", "last", "dual"}))
      ->each([o = opts.get()](const std::string& w) { o->returns = *parse_return_selection(w); });
  cmd->add_option("--min-range", opts->min_range, "drop points closer than M metres")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--max-range", opts->max_range, "drop points farther than M metres (default: no limit)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--cut-angle", opts->cut_angle, "azimuth in degrees where a scan ends (default 0: the wrap)")
      ->check(CLI::Range(0.0, 359.99))
      ->capture_default_str();
  cmd->add_option("--azimuth", "Velodyne point azimuth: per-laser (default, the manuals' firing times) or "
                  "per-sequence (VeloView)")
      ->check(CLI::IsMember({"per-laser", "per-sequence"}))
      ->each([o = opts.get()](const std::string& w) { o->azimuth = *parse_azimuth_interpolation(w); });
  cmd->add_option("--fov", opts->fov,
                  "START,END: the sensor's FOV setting in degrees, clockwise (only gaps inside it are missing packets)")
      ->delimiter(',')
      ->expected(2);
  cmd->add_option("--out", opts->out, "output directory for scan_NNNNNN.pcd")->required();
  cmd->callback([opts, &ctx] { ctx.exit_code = run_decode(*opts); });
}

}  // namespace sensor_rig::drivers
